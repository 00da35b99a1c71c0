"""GAN pre-completion (paper section III-A; docs/design.md section 3).

:mod:`~gmcpt.gan.model` generator and critic, :mod:`~gmcpt.gan.losses` the
hybrid loss, :mod:`~gmcpt.gan.train` the training loop (``python -m gmcpt
train``), :mod:`~gmcpt.gan.weights` shipped weights I/O,
:mod:`~gmcpt.gan.infer` full-frame inference. The completion methods ``gan``
and ``gan_pawnnm`` are in :mod:`gmcpt.completion.learned`.
"""
