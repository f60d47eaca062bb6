"""The motivator: self-generated events chosen by reward and social cost, and the controller's store.

:mod:`~cyborg.motivator.logic` makes the choice (pure), :mod:`~cyborg.motivator.component` wires
it to the transport, and :mod:`~cyborg.motivator.store` keeps what the controller must not
forget (emotion, switch, saturations) in SQLite.
"""
