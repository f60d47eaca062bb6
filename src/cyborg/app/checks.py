"""What ``cyborg validate`` checks about the whole robot, beyond each file's schema.

When a configuration starts its own modules (a ``modules:`` section), it can see mistakes
that no single block shows: a state whose action no module serves (the controller would
take ``aborted``), a resource granted to a node that is no module (the gatekeeper would drop
what the module says), and two modules listening for the same phrase (they would race for
one sentence). These are warnings: an external node may serve the action or hold the resource.
"""

from __future__ import annotations

from collections import defaultdict

from cyborg.app.config import LoadedConfig
from cyborg.app.registry import KindRegistry
from cyborg.modules.kind import ModuleSettings

__all__ = ["robot_warnings"]


def robot_warnings(config: LoadedConfig, kinds: KindRegistry) -> list[str]:
    """Warnings about the robot ``config`` describes; none when it has no ``modules:`` section.

    The modules' settings must be valid (``KindRegistry.check``); nothing is started.
    """
    modules = config.model.modules
    if not modules:
        return []
    settings: dict[str, ModuleSettings] = {
        name: kinds.parse(name, raw, source=config.source)[1] for name, raw in modules.items()
    }
    served = {action.lstrip("/") for s in settings.values() for action in s.serves()}
    warnings: list[str] = []
    for leaf in config.machine.leaves():
        action = (leaf.action or "").lstrip("/")
        if action not in served:
            warnings.append(
                f"state {leaf.name!r}: no module in this file serves its action {leaf.action!r}, so the "
                f"controller takes 'aborted' unless an external node offers it; fix: add a module that "
                f"serves it (e.g. {{kind: placeholder, servers: [{{action: {action}}}]}}) or start that node"
            )
    for state in config.machine.states.values():
        for resource, holder in state.resources.items():
            if holder not in modules:
                warnings.append(
                    f"state {state.name!r}: resource {resource!r} goes to {holder!r}, which is no module's node "
                    f"in this file, so its gatekeeper drops what the modules send; fix: name the module's "
                    f"node (one of {', '.join(sorted(modules))}) or start the node {holder!r}"
                )
    listeners: defaultdict[str, list[str]] = defaultdict(list)
    for name, module_settings in settings.items():
        for phrase in dict.fromkeys(p.strip().lower() for p in module_settings.listens_for()):
            listeners[phrase].append(name)
    for phrase, names in sorted(listeners.items()):
        if len(names) > 1:
            warnings.append(
                f"modules {' and '.join(repr(n) for n in names)} both listen for {phrase!r}: both react to "
                f"one sentence and race for control; fix: let one of them listen for another phrase"
            )
    return warnings
