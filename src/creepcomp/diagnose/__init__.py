"""Diagnosis of a record: what the creep model (sensor side) or the nominal network (circuit
side) gets wrong, and which effect explains it."""
