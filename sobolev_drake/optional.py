"""Optional dependencies, imported on first use with an install line when missing.

``import sobolev_drake`` needs only the core dependencies; a feature that needs an extra imports
it through here, so a missing package is named together with the extra that provides it.
"""

from __future__ import annotations

from types import ModuleType

__all__ = ["python_control"]


def python_control(feature: str) -> ModuleType:
    """The ``control`` module (python-control), imported on first use.

    Parameters
    ----------
    feature : str
        What needs it (named in the error).

    Returns
    -------
    module
        ``control``.

    Raises
    ------
    ImportError
        When python-control is not installed, naming ``feature`` and
        ``pip install 'sobolev_drake[control]'``.

    Examples
    --------
    >>> from sobolev_drake.optional import python_control
    >>> python_control("an example").ss([[-1.0]], [[1.0]], [[1.0]], [[0.0]]).poles()
    array([-1.+0.j])
    """
    try:
        import control
    except ImportError:
        raise ImportError(f"{feature} needs python-control (and slycot): "
                          "pip install 'sobolev_drake[control]'") from None
    return control
