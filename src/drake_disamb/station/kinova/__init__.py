"""A real Kinova Gen2 arm behind Drake's Kinova messages, through Kinova's own SDK (no ROS).

The driver process (``drake-disamb mico-driver --kinova-sdk LIB``) loads Kinova's Gen2 SDK command
layer at run time with :mod:`ctypes` (the user installs Kinova's SDK; we never ship it):

- :mod:`~drake_disamb.station.kinova.structs`: the SDK's structures and constants, laid out as
  Kinova's public header ``KinovaTypes.h`` declares them;
- :mod:`~drake_disamb.station.kinova.sdk`: the library loaded and checked, each call's result
  code checked (:class:`~drake_disamb.station.kinova.sdk.KinovaSdk`), and the session with one
  arm (:class:`~drake_disamb.station.kinova.sdk.KinovaArm`: opened, checked to be a 6-joint MICO,
  angular control started, stopped and closed on every way out);
- :mod:`~drake_disamb.station.kinova.driver`: the loop (statuses out, velocity points in, the
  driver's own safety) and the period it holds on the link.
"""
