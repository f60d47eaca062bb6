"""Behaviour modules and the helper that makes writing one a few lines."""
