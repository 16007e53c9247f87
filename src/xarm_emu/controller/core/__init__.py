"""The core of the controller: what every handler, device and application stands on.

The control period, command outcomes and the interfaces components plug in through
(:mod:`.interface`), the motion state machine (:mod:`.state_machine`), the controller's mutable state
(:mod:`.controller_state`), the fault group, settings and their saved files, the command buffer and
its execution (:mod:`.commands`, :mod:`.executor`, :mod:`.poses`), the per-step safety checks, the
feedback queue of firmware 2.x and the joints' thermal model.
"""
