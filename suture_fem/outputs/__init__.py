"""Outputs: one small class per quantity, field files, and the typed results that write results.json."""
