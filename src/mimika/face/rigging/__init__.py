"""Rigging any face mesh with seed-002 fields: find its face (:mod:`.features`), bring it into
mimika's frame (:mod:`.frame`), place its landmarks (:mod:`.landmarks`), generate shapes from
the shipped fields (:mod:`.generate`), compose the AU rig (:mod:`.assemble`); ``mimika rig``
(:mod:`.autorig`) writes the result as GLB (:mod:`.export`)."""
