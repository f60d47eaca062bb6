"""Motivator of the controller core: picks self-generated events by a reward-cost rule."""
