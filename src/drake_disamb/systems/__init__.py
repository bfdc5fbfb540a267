"""Drake LeafSystems that wrap the numpy core (:mod:`drake_disamb.core`)."""
