"""The analog correction network: sizing, predicted quality, E-series parts, faults and fixes."""
