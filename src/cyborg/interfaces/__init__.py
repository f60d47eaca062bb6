"""User interfaces: the `cyborg` command line and the dashboard."""
