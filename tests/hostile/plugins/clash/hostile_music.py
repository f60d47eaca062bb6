"""What `cyborg new module music` wrote before it refused the name: a kind named like a built-in."""

from cyborg.modules.placeholder import KIND

__all__ = ["KIND"]
