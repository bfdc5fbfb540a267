"""A real Kinova Gen2 arm behind Drake's Kinova messages, through Kinova's own SDK (no ROS).

Kinova's Gen2 SDK command layer is loaded at run time with :mod:`ctypes` (the user installs
Kinova's SDK; we never ship it):

- :mod:`~drake_disamb.station.kinova.structs`: the SDK's structures and constants, laid out as
  Kinova's public header ``KinovaTypes.h`` declares them;
- :mod:`~drake_disamb.station.kinova.sdk`: the library loaded and checked, each call's result
  code checked (:class:`~drake_disamb.station.kinova.sdk.KinovaSdk`), and the session with one
  arm (:class:`~drake_disamb.station.kinova.sdk.KinovaArm`: opened, checked to be a 6-joint MICO,
  angular control started, stopped and closed on every way out).
"""
