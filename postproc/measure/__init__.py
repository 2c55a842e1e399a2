"""Measurements and what they say: the readers, ballbar analysis and fits, probing, screening, budgets."""
