# SPDX-License-Identifier: MIT
# The built-in modalities as Python sees them.
import ced


def test_every_builtin_modality_has_a_helper():
    # The built-in list (ced/modalities/builtin.hpp) is what the helpers follow: a built-in without a helper of
    # its own gets a generic one, ced.<name>(threshold=None, fields=None, **options).
    builtins = [name for name, _ in ced._ced._builtin_modalities()]
    assert {"xyz", "rgb", "lab", "normals", "intensity", "bands"} <= set(builtins)
    assert len(set(builtins)) == len(builtins)
    registered = dict(ced.modalities())
    for name in builtins:
        assert name in ced.__all__ and callable(getattr(ced, name)), name
        assert name in registered, name
    generic = ced._builtin_helper("intensity", "a scalar field")
    assert generic.__name__ == "intensity" and "a scalar field" in generic.__doc__
    made, written = generic(0.05, "green", range=(0, 255)), ced.intensity(0.05, "green", range=(0, 255))
    assert (made.name, made.fields, made.threshold()) == (written.name, written.fields, written.threshold())
    assert made.fields == ["green"]
