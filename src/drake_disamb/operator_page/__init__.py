"""The operator page: the Meshcat scene with a panel beside it that says what the robot believes
and why (docs/operator_page.md).

:mod:`~drake_disamb.operator_page.model` is what the panel says (plain data and words),
:mod:`~drake_disamb.operator_page.server` the page's server on this machine (the panel to the page,
keys and gamepad from it), :mod:`~drake_disamb.operator_page.replay` the panel kept in a saved
recording; ``operator.html``, ``panel.js`` and ``panel.css`` are the page itself. No Drake here:
:class:`~drake_disamb.systems.panel.OperatorPanel` feeds it from a diagram.
"""
