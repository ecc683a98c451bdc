"""Backends: segmenters, matchers, lifters and feature extractors behind protocols and registries."""
