# SPDX-License-Identifier: MIT
# The type stubs (.pyi) describe the package as it is: the same names, the same parameters.
import ast
import inspect
import pathlib
import re

import pytest

import ced
import ced.eval

PACKAGE = pathlib.Path(ced.__file__).resolve().parent


def stub_functions(name):
    tree = ast.parse((PACKAGE / name).read_text())
    functions, classes = {}, set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            a = node.args
            functions[node.name] = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
        elif isinstance(node, ast.ClassDef):
            classes.add(node.name)
    return functions, classes


def parameters(fn):
    try:
        return list(inspect.signature(fn).parameters)
    except ValueError:  # a pybind11 function: its first signature line
        head = fn.__doc__.splitlines()[0]
        inside = head[head.index("(") + 1:head.rindex(")")]
        return [p.split(":")[0].strip() for p in inside.split(", ") if p]


@pytest.mark.parametrize("module, stub", [(ced, "__init__.pyi"), (ced.eval, "eval.pyi")])
def test_stubs_match_the_package(module, stub):
    functions, classes = stub_functions(stub)
    public = set(module.__all__) - {"eval", "__version__"}
    # Helpers made from the built-in list for modalities without one of their own: the stub's __getattr__.
    generated = {name for name in public if getattr(getattr(module, name), "__code__", None) is
                 getattr(ced._builtin_helper("x", ""), "__code__", 0)} if module is ced else set()
    assert not generated or "__getattr__" in functions
    functions.pop("__getattr__", None)
    assert public - generated == set(functions) | classes
    for name, params in functions.items():
        assert parameters(getattr(module, name)) == params, name


def stub_members(name):
    """Each stub class's public members: methods, properties and annotated attributes."""
    tree = ast.parse((PACKAGE / name).read_text())
    members = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            names = {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
            names |= {n.target.id for n in node.body if isinstance(n, ast.AnnAssign)}
            members[node.name] = {n for n in names if not n.startswith("_")}
    return members


@pytest.mark.parametrize("module, stub", [(ced, "__init__.pyi"), (ced.eval, "eval.pyi")])
def test_stub_classes_have_the_packages_members(module, stub):
    # (What a class inherits, from OSError say, is its base's to describe.)
    for name, members in stub_members(stub).items():
        cls = getattr(module, name)
        inherited = set().union(*(dir(b) for b in cls.__bases__))
        public = {a for a in dir(cls) if not a.startswith("_") and a not in inherited}
        assert public == members, name


@pytest.mark.parametrize("module", [ced, ced.eval])
def test_docstrings_are_present(module):
    for name in module.__all__:
        obj = getattr(module, name)
        if callable(obj):
            assert obj.__doc__ and obj.__doc__.strip(), name


def stub_docstring(name, function):
    tree = ast.parse((PACKAGE / name).read_text())
    node = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == function)
    return " ".join(ast.get_docstring(node).split())


@pytest.mark.parametrize("function, pattern", [("preset", r"'(\w+)' \(([^)]*)\)"),
                                               ("preset_keypoint_share", r"([0-9.]+) for (\w+)")])
def test_preset_docstrings_say_what_the_stub_says(function, pattern):
    # tests/test_docs.cpp checks the stub against the registry; here the module's own docstrings.
    runtime = re.findall(pattern, " ".join(getattr(ced, function).__doc__.split()))
    stub = re.findall(pattern, stub_docstring("__init__.pyi", function))
    assert runtime and sorted(runtime) == sorted(stub)
