"""Breakage models: Weibull disk fracture (seed 000) and the Tavares model with particle replacement (seed 002)."""
