"""Scoring a model against the encoder: RMSE and shares (metrics), the lookup baseline
(baseline), the native replay through the board observer's C++ (replay), and a trained
model scored on every row of recordings it never saw (evaluate).

May import: the foundations, hpddo.logs, hpddo.model and hpddo.ripple (the speed scored against).
"""
