"""Breakage models: Weibull disk fracture (seed 000); Tavares (seed 002) to come."""
