"""The one exception type the command line turns into a one-line message."""


class GmcptError(Exception):
    """A user-facing error: bad input, a missing file, an unusable setup.

    The CLI prints ``error: <message>`` on one line and exits non-zero; library
    callers can catch it like any other exception.
    """


class BadValue(GmcptError, ValueError):
    """A bad argument to a library function: a :class:`GmcptError`, and a ``ValueError`` as these functions raised before."""
