"""Emotion system of the controller core: PAD model, emotion naming and its persistent store."""
