"""One of two packages offering the kind dupkind."""

from cyborg.modules.placeholder import KIND

__all__ = ["KIND"]
