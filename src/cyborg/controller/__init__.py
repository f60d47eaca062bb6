"""Controller core: state machine configuration, transition logic and runtime."""
