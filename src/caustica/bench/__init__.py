"""Measurement harness: ``compare`` (accuracy against ground truth) and ``bench`` (speed)."""
