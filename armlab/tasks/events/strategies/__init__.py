"""The kit's own strategies of the three events (instructor only: left out of the student release, where they are
the answers of the exercises events.sort_stack, events.line_up and events.sky; the release's events stand in with
the generic search of armlab.tasks.events.search).

Each module defines one Strategy class: sort_stack.SortStack, line_up.LineUp, sky.Sky. The event modules
(armlab.tasks.events.sort_stack, line_up, sky) keep the rules, the board's given spots and the EventSpec, whose
strategy is kit_or_search's: this package's class when it is installed, the search otherwise.
"""
