"""Evaluation: predictions files, ground truth, metrics, the VOS-DE baseline and the leaderboard.

A predictions file (predictions.py) is checked against the labels of the stores that hold its
splits (ground_truth.py) and scored with the metrics (metrics.py) into a report (scoring.py),
shown as a table (score_tables.py) or a plot (error_plots.py), or turned into an entry of the
leaderboard (leaderboard.py). vosde.py is the least-squares baseline.
"""
