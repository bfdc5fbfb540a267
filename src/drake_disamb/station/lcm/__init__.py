"""The station on LCM: a Kinova Gen2 arm (or our simulated one) behind Drake's Kinova messages.

- :mod:`~drake_disamb.station.lcm.mapping`: Kinova's actuator angles and finger units <-> our
  model's DH angles and finger slides;
- :mod:`~drake_disamb.station.lcm.messages`: ``lcmt_jaco_status`` / ``lcmt_jaco_command`` checked
  and built in our model's terms;
- :mod:`~drake_disamb.station.lcm.bus`: the status inbox and the command link;
- :mod:`~drake_disamb.station.lcm.faults`: the faults the station latches;
- :mod:`~drake_disamb.station.lcm.systems`: the receiver, the model's end-effector state, the sender;
- :mod:`~drake_disamb.station.lcm.station`: the assembly, with the start checks;
- :mod:`~drake_disamb.station.lcm.driver`: the simulated driver (``drake-disamb mico-driver``).
"""
