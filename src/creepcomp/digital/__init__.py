"""Digital creep correction of sampled signals: the recursive correctors, the paper's
literal formulas, and the paper's test scenarios."""
