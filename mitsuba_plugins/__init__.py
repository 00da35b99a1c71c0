"""Mitsuba plugins of the gmcpt project.

Importing this package (or ``gmcpt``) prepares Mitsuba (LLVM lookup, variant)
and registers the ``masked_path`` integrator for the active variant.
"""
import gmcpt  # noqa: F401  (configures LLVM and the Mitsuba variant first)

from .masked_path import MaskedPathIntegrator, register

register()

__all__ = ["MaskedPathIntegrator", "register"]
