"""The type stubs name what the package has, and the package what the stubs name."""

import ast
from pathlib import Path

import gradtac
import gradtac._gradtac as core

PKG = Path(__file__).resolve().parents[1] / "gradtac"


def names(stub: Path):
    tree = ast.parse(stub.read_text())
    top, classes = set(), {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            top.add(node.name)
        if isinstance(node, ast.ClassDef):
            classes[node.name] = {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
    return top, classes


def test_stubs_match_the_modules():
    for stub, module in ((PKG / "__init__.pyi", gradtac), (PKG / "_gradtac.pyi", core)):
        top, classes = names(stub)
        for name in top:
            assert hasattr(module, name), f"{stub.name}: {name}"
        for cls, methods in classes.items():
            for m in methods - {"__init__"}:
                assert hasattr(getattr(module, cls), m), f"{stub.name}: {cls}.{m}"
    assert set(gradtac.__all__) <= names(PKG / "__init__.pyi")[0] | {"Scene", "GradtacError"}
    for name in gradtac.__all__:
        obj = getattr(gradtac, name)
        assert obj.__doc__, f"{name} has no docstring"
