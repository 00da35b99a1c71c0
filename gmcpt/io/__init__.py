"""Files: writing them safely (:mod:`~gmcpt.io.files`), the multi-layer EXR and its PNG preview
(:mod:`~gmcpt.io.exr`), a render's three outputs (:mod:`~gmcpt.io.outputs`), the sensor's film after
``mi.render`` (:mod:`~gmcpt.io.film`), movies (:mod:`~gmcpt.io.video`) and the training examples' ``.npz``
files (:mod:`~gmcpt.io.examples`).

Above :mod:`gmcpt.image` (the EXR's coverage layer is the working domain's); everything that writes or reads a
file builds on it (docs/design.md, "Layers").
"""
