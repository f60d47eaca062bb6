"""Navigation module: known places, scheduled visits, keyword detection and what to say about places."""
