"""The emotion system: the PAD model and the component that keeps the robot's emotion.

:mod:`~cyborg.emotion.model` holds the thesis's formulas and emotion names (pure);
:mod:`~cyborg.emotion.system` the component on the transport. Its memory is the controller's
store (:mod:`cyborg.motivator.store`), seen through a protocol.
"""
