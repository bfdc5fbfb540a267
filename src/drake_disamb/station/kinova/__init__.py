"""A real Kinova Gen2 arm behind Drake's Kinova messages through Kinova's own Gen2 SDK, with no ROS
(``drake-disamb mico-driver --kinova-sdk LIB``): the SDK's command layer loaded at run time with
:mod:`ctypes` (the user installs Kinova's SDK; we never ship it), the session with one arm, and the
driver's loop with its own safety (docs/real_arm.md).

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""
