"""Helpers for graphseg's own test suite (plugins registered through entry points)."""
