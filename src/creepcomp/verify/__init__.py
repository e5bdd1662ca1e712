"""Proof of a design: ngspice netlists and simulation, Monte Carlo and worst-case tolerances."""
