"""Declared parameters (pftrack.components.Param): the generated __init__, signature, docstring,
inheritance and redeclaration, and the scikit-learn conventions the conformance kit checks."""

from __future__ import annotations

import inspect

import numpy as np
import pytest
from pftrack.components import Likelihood, Param
from pftrack.testing import check_component


class _Base(Likelihood):
    """A base.

    {params}
    """

    scale: float = Param(2.0, "Scale, pixels.")
    floor: float = Param(0.0, "Added to every log-likelihood.")

    def log_likelihood(self, boxes_xywh_px, target):
        b = np.asarray(boxes_xywh_px, dtype=np.float64)
        return -b[:, 0] / float(self.scale) + float(self.floor)


class _Child(_Base):
    """A child with one more parameter and a new default for ``scale``.

    {params}
    """

    scale: float = Param(5.0, "Scale, pixels (the child's default).")
    name_tag: str = Param("x", "A tag.")


class _Required(Likelihood):
    must: float = Param(doc="No default.")

    def log_likelihood(self, boxes_xywh_px, target):
        return np.zeros(len(boxes_xywh_px))


def test_generated_init_signature_and_storage():
    sig = inspect.signature(_Child.__init__)
    assert list(sig.parameters) == ["self", "scale", "floor", "name_tag"]  # the base's first
    assert sig.parameters["scale"].default == 5.0
    c = _Child(floor=1.5)
    assert c.get_params() == {"scale": 5.0, "floor": 1.5, "name_tag": "x"}
    assert _Base().get_params() == {"scale": 2.0, "floor": 0.0}
    with pytest.raises(TypeError, match=r"unexpected parameters \['bogus'\]"):
        _Child(bogus=1)
    with pytest.raises(TypeError, match="missing parameter 'must'"):
        _Required()
    assert _Required(must=3).must == 3


def test_docstring_gets_a_numpydoc_parameters_section():
    doc = _Child.__doc__
    assert "{params}" not in doc
    assert "    Parameters\n    ----------\n    scale : float\n        Scale, pixels (the child's" \
        in doc
    assert "    name_tag : str\n        A tag." in doc
    assert "Scale, pixels.\n" in _Base.__doc__


def test_declared_components_pass_the_conformance_kit():
    assert all(r.passed for r in check_component(_Child))
