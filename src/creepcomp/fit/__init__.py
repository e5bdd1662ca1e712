"""Prony identification of a creep model from a record: data, noise, solver, evidence, order."""
