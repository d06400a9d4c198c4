"""The rig's physics, defined once: the element algebra of gas films, the effects a real rig adds, the rig spec
and the response of a spec to a force. It imports numpy, scipy and the project's error types only; the simulator,
the replay, identification and the diagnosis all use it.
"""
