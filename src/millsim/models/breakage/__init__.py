"""Breakage models: Weibull disk fracture (Buchholtz et al. 2000) and the Tavares model with
particle replacement (Tavares et al. 2021)."""
