"""What works on one image and its feature buffers alone, with no renderer and no learned parameters: the
completion stages' working domain (:mod:`~gmcpt.image.domain`), the feature-guided and pyramid fills
(:mod:`~gmcpt.image.fills`, their torch kernel :mod:`~gmcpt.image.fill_kernel`), Intel OIDN
(:mod:`~gmcpt.image.denoise`) and the image metrics (:mod:`~gmcpt.image.metrics`).

Above :mod:`gmcpt.runtime`; the sampling, the completion methods, the GAN and the low-rank stage all build on it
(docs/design.md, "Layers").
"""
