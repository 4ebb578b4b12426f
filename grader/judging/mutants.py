"""Mistakes generated from the reference: every single slip of a graded function, made mechanically.

Mutation testing (mutmut, cosmic-ray) makes every small change of a piece of code to see whether the
tests notice it. Here the same idea runs the other way round: the small changes of each graded
function's reference (solutions/chNN_*.py, at the level of its Python AST) are the slips learners make,
and a learner whose outputs equal one of them at every input of a check has made that slip. The slips:

- a term dropped from a sum; a sign flipped (+ for -, a minus missing, a difference the wrong way round);
- a factor 2 or 1/2 too many (a 2 or 0.5 left out; the whole value doubled or halved; the step h or dt
  used as h/2 or 2h); a power off by one (x for x^2, x^3 for x^2, a square root missing, the square of
  the whole value);
- sin for cos and back; the arguments of a call, the operands of a matrix product or two of the
  function's own arguments swapped; a transpose missing;
- degrees for radians (angles read as degrees, or an angle returned in degrees);
- the point of evaluation moved (a callable evaluated at x where a belongs; the new state where the
  old one belongs);
- integer arithmetic (no conversion to float, so x + h is truncated);
- mean, sum, max and min for one another (also argmin for argmax); an index for the value it indexes;
- a missing normalisation; a missing absolute value.

Each mutant has a stable key, a kind (its name, as reports count it) and one sentence in the lesson's
language generated from the mutation (what the slip does, never the reference code or the right
formula). Instructor side only: it reads the references, so it is never imported where learner code
runs (pyproject's import contracts), and a handout holds only the values the mutants gave at the
checks' inputs, recorded by grader.judging.expected, never a mutated source (grader.course.release scans for them).
"""

from __future__ import annotations

import ast
import contextlib
import copy
import functools
import importlib
import inspect
import warnings
from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np

from grader.chapters import BY_ID

TRIG = {"sin": "cos", "cos": "sin"}
ANGLE_IN = ("sin", "cos", "tan")
ANGLE_OUT = ("arctan2", "arctan", "arcsin", "arccos")
REDUCTIONS = {"max": "the largest value", "min": "the smallest value", "mean": "the mean", "sum": "the sum"}
ARG_REDUCTIONS = {"argmin": "the smallest", "argmax": "the largest"}
NORMS = ("hypot", "norm", "sqrt")
CONVERSIONS = ("float", "asarray", "array", "atleast_1d")
STEPS = ("h", "dt")  # arguments that are steps: used as h/2 or 2h is a slip of its own
# calls whose arguments are sizes, shapes or indices: never mutated (a mutant must stay cheap and finite)
SIZES = ("range", "zeros", "ones", "empty", "eye", "standard_normal", "normal", "uniform", "integers", "reshape",
         "int", "len", "full", "zeros_like", "ones_like", "empty_like", "enumerate", "stack", "column_stack")
SEEDS = ("default_rng",)  # a seed is a large integer: never swapped into a size either
MATH_NAMES = {"sin", "cos", "tan", "sqrt", "exp", "log", "hypot", "arctan2", "arctan", "abs", "dot"}
PRECEDENCE = {ast.Add: 1, ast.Sub: 1, ast.Mult: 2, ast.Div: 2, ast.MatMult: 2, ast.Pow: 4}
RENDER_LIMIT = 24  # a term longer than this, as the lesson writes it, is not quoted


# a plus for a minus or the other way round: which one the learner's form has depends on their parentheses
# (a - (b + c) slipped as a - b + c has a plus where the value needs a minus), so the sentence says neither
SIGN = "one sign is wrong: one term enters with the opposite sign (mind the parentheses of a difference)."


@dataclass(frozen=True)
class Mutant:
    """One slip of a reference function: `function` computes what a learner making it returns."""

    key: str  # "tangent_plane#3": stable while the reference does not change
    name: str  # the kind of slip, as reports count it: "missing term", "factor 2", ...
    help: str  # one sentence in the lesson's language
    source: str  # the mutated function's source: instructor side only, never recorded or shown
    function: Callable


class Unavailable(LookupError):
    """The references are not installed here (a handout, or a grader installed without its project)."""


# ------------------------------------------------------------------------------ the reference's syntax tree

def _module_of(chapter: str, function: str):
    """The module of the chapter's reference solution that defines `function` (maybe an earlier chapter's)."""
    try:
        module = importlib.import_module(f"solutions.{BY_ID[chapter].module}")
    except ModuleNotFoundError as exc:
        raise Unavailable(f"the references are not installed here ({exc})") from None
    target = getattr(module, function, None)
    if not callable(target):
        raise Unavailable(f"{chapter} has no reference {function}")
    return importlib.import_module(target.__module__)


@functools.lru_cache(maxsize=None)
def _tree(module_name: str) -> ast.Module:
    module = importlib.import_module(module_name)
    return ast.parse(inspect.getsource(module))


def _definition(module, function: str) -> ast.FunctionDef:
    for node in _tree(module.__name__).body:
        if isinstance(node, ast.FunctionDef) and node.name == function:
            node = copy.deepcopy(node)
            if node.body and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant):
                node.body = node.body[1:] or [ast.Pass()]  # the docstring says what it computes: not a slip site
            node.returns = None
            for arg in node.args.args + node.args.kwonlyargs:
                arg.annotation = None
            return node
    raise Unavailable(f"{module.__name__} has no function {function}")


def _callee(node: ast.AST) -> str:
    """The called name: np.linalg.norm -> norm, rng.standard_normal -> standard_normal, f -> f."""
    if isinstance(node, ast.Call):
        node = node.func
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Name):
        return node.id
    return ""


class _Shape:
    """What the mutations need to know of one function: its arguments, the callables among them, the
    names that are only conversions of an argument (xs for x), and every node's parent."""

    def __init__(self, fdef: ast.FunctionDef) -> None:
        self.fdef = fdef
        self.params = [a.arg for a in fdef.args.args + fdef.args.kwonlyargs]
        self.nodes = list(ast.walk(fdef))
        self.parent: dict[int, ast.AST] = {}
        for node in self.nodes:
            for child in ast.iter_child_nodes(node):
                self.parent[id(child)] = node
        self.callables = {_callee(n) for n in self.nodes if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)
                          and n.func.id in self.params}
        # the arguments that set a size (n in standard_normal((int(n), 2))): never swapped with another (a seed
        # for n would ask for billions of samples)
        self.sizes = {n.id for call in self.nodes if isinstance(call, ast.Call) and _callee(call) in SIZES + SEEDS
                      for arg in call.args for n in ast.walk(arg) if isinstance(n, ast.Name) and n.id in self.params}
        self.sizes |= {p for p in self.params if p in ("n", "seed")}  # passed on to a helper that draws n samples
        self.alias: dict[str, str] = {p: p for p in self.params}  # name -> the argument it converts
        self.assigned: dict[str, ast.AST] = {}
        for node in self.nodes:
            if isinstance(node, ast.Assign) and len(node.targets) == 1:
                self._learn(node.targets[0], node.value)

    def _learn(self, target: ast.AST, value: ast.AST) -> None:
        if isinstance(target, ast.Name):
            self.assigned[target.id] = value
            source = self._converted(value)
            if source is not None and source in self.alias:
                self.alias[target.id] = self.alias[source]
        elif isinstance(target, ast.Tuple) and isinstance(value, ast.Tuple) and len(value.elts) == len(target.elts):
            for t, v in zip(target.elts, value.elts):
                self._learn(t, v)
        elif isinstance(target, ast.Tuple) and self._converted(value) in self.params:
            for t in target.elts:  # a vector argument unpacked into its entries: each stands for itself
                if isinstance(t, ast.Name):
                    self.alias[t.id] = t.id

    def _converted(self, value: ast.AST) -> str | None:
        """`x` for float(x), np.asarray(x, dtype=float), x itself; else None."""
        while isinstance(value, ast.Call) and _callee(value) in CONVERSIONS and value.args:
            value = value.args[0]
        return value.id if isinstance(value, ast.Name) else None

    def up(self, node: ast.AST) -> ast.AST | None:
        return self.parent.get(id(node))

    def mutable(self, node: ast.AST) -> bool:
        """Whether a slip may be made here: not in a condition, a raise, a loop's range, an index, a size or a
        target of an assignment."""
        child, parent = node, self.up(node)
        while parent is not None:
            if isinstance(parent, (ast.Raise, ast.Assert)) or isinstance(parent, (ast.If, ast.While)) and \
                    child is parent.test:
                return False
            if isinstance(parent, (ast.For, ast.comprehension)) and child is not getattr(parent, "body", None) and \
                    (child is parent.iter or child is parent.target):
                return False
            if isinstance(parent, ast.Subscript) and child is parent.slice:
                return False
            if isinstance(parent, ast.Assign) and child in parent.targets:
                return False
            if isinstance(parent, ast.Call) and _callee(parent) in SIZES:
                return False
            if isinstance(parent, ast.keyword) and parent.arg != "dtype":
                return False
            child, parent = parent, self.up(parent)
        return True

    # -------------------------------------------------------------- how the lesson writes a term

    def render(self, node: ast.AST) -> str | None:
        """A term as the lesson writes it, if it is one of the arguments, a number, or a function of arguments
        ("x", "dt", "f(a)", "cos(th)"); else None. Sums, products and quotients are never quoted: a sentence
        names where the slip is, never a piece of the right formula."""
        try:
            text = self._render(node, 0)
        except ValueError:
            return None
        compound = any(isinstance(n, ast.BinOp) for n in ast.walk(node))
        return text if len(text) <= RENDER_LIMIT and not compound else None

    def _render(self, node: ast.AST, outer: int) -> str:
        if isinstance(node, ast.Name):
            if node.id not in self.alias:
                raise ValueError(node.id)
            return self.alias[node.id]
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            return f"{node.value:g}"
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            return "-" + self._render(node.operand, 3)
        if isinstance(node, ast.BinOp) and type(node.op) in PRECEDENCE:
            mine = PRECEDENCE[type(node.op)]
            left, right = self._render(node.left, mine), self._render(node.right, mine + 1)
            symbol = {ast.Add: " + ", ast.Sub: " - ", ast.Mult: " ", ast.Div: "/", ast.MatMult: " ",
                      ast.Pow: "^"}[type(node.op)]
            text = f"{left}{symbol}{right}"
            return f"({text})" if mine < outer else text
        if isinstance(node, ast.Call) and not node.keywords:
            name = _callee(node)
            if name in CONVERSIONS and len(node.args) == 1:
                return self._render(node.args[0], outer)
            if name in self.callables or name in MATH_NAMES:
                shown = {"arctan2": "atan2", "arctan": "atan"}.get(name, name)
                return f"{shown}({', '.join(self._render(a, 0) for a in node.args)})"
        raise ValueError(ast.dump(node))

    def role(self, node: ast.AST) -> tuple[str, int]:
        """Where `node` acts on the result: ("whole", p), ("term", p), ("entry", p) or ("nested", p), with p = +1
        where it multiplies that part and -1 where it divides it."""
        power, role, child, parent = 1, "whole", node, self.up(node)
        while parent is not None and not isinstance(parent, ast.Return):
            if isinstance(parent, ast.BinOp) and isinstance(parent.op, ast.Mult) or isinstance(parent, ast.UnaryOp):
                pass
            elif isinstance(parent, ast.BinOp) and isinstance(parent.op, ast.Div):
                if child is parent.right:
                    power = -power
            elif isinstance(parent, ast.BinOp) and isinstance(parent.op, (ast.Add, ast.Sub)):
                role = "term" if role == "whole" else role
            elif isinstance(parent, (ast.List, ast.Tuple)):
                role = "entry"
            elif isinstance(parent, ast.Call) and _callee(parent) in CONVERSIONS:
                pass
            else:
                return "nested", power
            child, parent = parent, self.up(parent)
        return (role, power) if parent is not None else ("nested", power)


# ------------------------------------------------------------------------------ the slips

Change = tuple[str, str, Callable[[ast.AST], ast.AST]]  # (kind, sentence, what the node becomes)


def _name(id_: str) -> ast.Name:
    return ast.Name(id=id_, ctx=ast.Load())


def _np(attr: str, *args: ast.AST) -> ast.Call:
    return ast.Call(func=ast.Attribute(value=_name("np"), attr=attr, ctx=ast.Load()), args=list(args), keywords=[])


def _is_two(node: ast.AST) -> float | None:
    if isinstance(node, ast.Constant) and not isinstance(node.value, bool) and node.value in (2, 0.5):
        return float(node.value)
    return None


def _scaled(role: tuple[str, int], factor: float) -> str:
    """The sentence for one part of the value multiplied by `factor` (2 or 0.5)."""
    kind, power = role
    larger = (factor > 1) == (power > 0)
    size = "a factor of 2 too large" if larger else "a factor of 2 too small (half the right value)"
    if kind == "whole":
        return f"your value is {size}."
    if kind == "term":
        return f"one of its terms is {size}."
    if kind == "entry":
        return f"one of its entries is {size}."
    return "a factor of 2 is " + ("too many" if larger else "missing") + " in one place."


def _node_changes(shape: _Shape, node: ast.AST) -> Iterator[Change]:
    """Every single slip at `node`."""
    render = shape.render
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
        kind, _ = shape.role(node)
        for dropped, kept in ((node.left, node.right), (node.right, node.left)):
            term = render(dropped)
            negate = isinstance(node.op, ast.Sub) and dropped is node.left
            keep = (lambda n, right=kept is node.right, negate=negate:
                    ast.UnaryOp(op=ast.USub(), operand=n.right) if negate else (n.right if right else n.left))
            if kind in ("whole", "term"):
                said = f"your value equals the right one without its term {term}." if term else \
                    "your value equals the right one without one of its terms."
            elif kind == "entry":
                said = f"one of its entries misses its term {term}." if term else "one of its entries misses a term."
            else:
                said = f"the term {term} is missing in one place." if term else "a term is missing in one place."
            yield "missing term", said, keep
        other = ast.Sub() if isinstance(node.op, ast.Add) else ast.Add()
        yield "sign", SIGN, lambda n, other=other: ast.BinOp(left=n.left, op=other, right=n.right)
        if isinstance(node.op, ast.Sub):
            yield "sign", "a difference is taken the wrong way round.", \
                lambda n: ast.BinOp(left=n.right, op=ast.Sub(), right=n.left)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
        yield "sign", "a minus sign is missing.", lambda n: n.operand
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        for dropped, kept in (("left", "right"), ("right", "left")):
            factor = getattr(node, dropped)
            if isinstance(factor, ast.Constant):
                continue  # a number: a factor 2 below, or no learner's slip
            term = render(factor)
            kind, _ = shape.role(node)
            where = {"whole": "your value misses", "term": "one of its terms misses", "entry": "one of its entries misses"}
            said = (f"{where[kind]} its factor {term}." if kind in where else f"the factor {term} is missing in one place.") \
                if term else (f"{where[kind]} one of its factors." if kind in where else "a factor is missing in one place.")
            yield "missing factor", said, lambda n, kept=kept: getattr(n, kept)
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Div)):
        for side in ("left", "right"):
            factor = _is_two(getattr(node, side))
            if factor is None or isinstance(node.op, ast.Div) and side == "left":
                continue
            role = shape.role(node)
            effect = 1 / factor if isinstance(node.op, ast.Mult) else factor  # what leaving it out does
            yield "factor 2", _scaled(role, effect), \
                lambda n, side=side: n.right if side == "left" else n.left
        norm = _callee(node.right) in NORMS or isinstance(node.right, ast.Name) and \
            _callee(shape.assigned.get(node.right.id, ast.Pass())) in NORMS
        if isinstance(node.op, ast.Div) and norm and shape.role(node)[0] == "whole":
            yield "not normalised", "your value is not normalised: divide it by the norm it is measured against (a " \
                                    "vector by its length).", lambda n: n.left
        elif isinstance(node.op, ast.Div) and _is_two(node.right) is None:
            divisor = render(node.right)
            kind, _ = shape.role(node)
            where = {"whole": "your value", "term": "one of its terms", "entry": "one of its entries"}.get(kind)
            said = (f"{where} misses the division by {divisor}." if where else
                    f"the division by {divisor} is missing in one place.") if divisor else \
                (f"{where} misses a division." if where else "a division is missing in one place.")
            yield "missing divisor", said, lambda n: n.left
        if isinstance(node.op, ast.Div):
            yield "reciprocal", "a ratio is upside down in one place.", \
                lambda n: ast.BinOp(left=n.right, op=ast.Div(), right=n.left)
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow) and isinstance(node.right, ast.Constant) and \
            isinstance(node.right.value, (int, float)) and not isinstance(node.right.value, bool):
        k = node.right.value
        base = render(node.left)
        for new in (k - 1, k + 1):
            if new == 0:
                continue
            if base:
                said = f"a power is off by one: {base}" + (f"^{new:g}" if new != 1 else "") + f" where {base}^{k:g} belongs."
            else:
                said = f"a power is one too {'low' if new < k else 'high'} in one place."
            yield "power", said, (lambda n, new=new: n.left if new == 1 else
                                  ast.BinOp(left=n.left, op=ast.Pow(), right=ast.Constant(new)))
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.MatMult):
        yield "order", "a matrix product is in the wrong order.", \
            lambda n: ast.BinOp(left=n.right, op=ast.MatMult(), right=n.left)
    if isinstance(node, ast.Attribute) and node.attr == "T" and isinstance(node.ctx, ast.Load):
        yield "transpose", "a transpose is missing in one place.", lambda n: n.value
    if isinstance(node, ast.Call):
        yield from _call_changes(shape, node)
    if isinstance(node, ast.Subscript) and any(_callee(n) in ARG_REDUCTIONS for n in ast.walk(node.slice)):
        seq = node.value.args[0] if isinstance(node.value, ast.Call) and _callee(node.value) == "list" and \
            node.value.args else node.value
        where = shape.render(seq)
        yield "index for value", (f"this is the index of the entry of {where} you chose, not the entry itself."
                                  if where else "this is an index, not the value it points to."), lambda n: n.slice


def _call_changes(shape: _Shape, node: ast.Call) -> Iterator[Change]:
    name = _callee(node)
    if name in TRIG and isinstance(node.func, ast.Attribute):
        arg = shape.render(node.args[0]) if node.args else None
        other = TRIG[name]
        said = f"{other}({arg}) where {name}({arg}) belongs." if arg else f"a {other} where a {name} belongs."
        yield "sin for cos", said, lambda n, other=other: ast.Call(
            func=ast.Attribute(value=n.func.value, attr=other, ctx=ast.Load()), args=n.args, keywords=n.keywords)
    if name == "sqrt" and node.args:
        yield "power", "a square root is missing in one place.", lambda n: n.args[0]
    if name in ("abs", "absolute") and node.args:
        yield "absolute value", "an absolute value is missing: your value keeps its sign.", lambda n: n.args[0]
    if name in REDUCTIONS and (node.args or isinstance(node.func, ast.Attribute) and name in ("max", "min", "mean",
                                                                                              "sum")):
        for other, said in REDUCTIONS.items():
            if other == name or isinstance(node.func, ast.Name) and other == "mean":
                continue
            yield "reduction", f"this takes {said} where {REDUCTIONS[name]} belongs.", \
                lambda n, other=other: ast.Call(func=ast.Attribute(value=n.func.value, attr=other, ctx=ast.Load())
                                                if isinstance(n.func, ast.Attribute) else ast.Name(id=other,
                                                                                                    ctx=ast.Load()),
                                                args=n.args, keywords=n.keywords)
    if name in ARG_REDUCTIONS and isinstance(node.func, ast.Attribute):
        other = "argmax" if name == "argmin" else "argmin"
        yield "reduction", f"this picks {ARG_REDUCTIONS[other]} where {ARG_REDUCTIONS[name]} belongs.", \
            lambda n, other=other: ast.Call(func=ast.Attribute(value=n.func.value, attr=other, ctx=ast.Load()),
                                            args=n.args, keywords=n.keywords)
    swappable = name in ("arctan2",) or name in shape.callables
    if swappable and len(node.args) >= 2 and not node.keywords:
        shown = {"arctan2": "atan2"}.get(name, name)
        for i in range(len(node.args) - 1):
            yield "arguments swapped", f"the arguments of {shown} are swapped.", \
                lambda n, i=i: ast.Call(func=n.func, args=n.args[:i] + [n.args[i + 1], n.args[i]] + n.args[i + 2:],
                                        keywords=n.keywords)
    if name in shape.callables:
        for position, arg in enumerate(node.args):
            if not isinstance(arg, ast.Name) or arg.id not in shape.alias:
                continue
            here = shape.alias[arg.id]
            others = [p for p in shape.params if p != here and p not in shape.callables]
            for other in others:
                target = next((n for n, a in shape.alias.items() if a == other and n != other), other)
                yield "point moved", f"{name} is evaluated at {other} where {here} belongs.", \
                    lambda n, position=position, target=target: ast.Call(
                        func=n.func, args=n.args[:position] + [_name(target)] + n.args[position + 1:],
                        keywords=n.keywords)


# ------------------------------------------------------------------------------ whole-function slips

def _function_changes(shape: _Shape) -> Iterator[tuple[str, str, Callable[[ast.FunctionDef], None]]]:
    """Slips of the whole function: (kind, sentence, what it does to a copy of the definition)."""
    calls = [n for n in shape.nodes if isinstance(n, ast.Call)]
    if any(_callee(c) in ANGLE_IN and isinstance(c.func, ast.Attribute) for c in calls):
        def degrees_in(copy_: ast.FunctionDef) -> None:
            for call in [n for n in ast.walk(copy_) if isinstance(n, ast.Call)]:
                if _callee(call) in ANGLE_IN and isinstance(call.func, ast.Attribute) and call.args:
                    call.args = [_np("radians", call.args[0])] + call.args[1:]
        yield "degrees", "the angles are read as degrees: they are in radians.", degrees_in
    if any(_callee(c) in ANGLE_OUT for c in calls):
        class Wrap(ast.NodeTransformer):
            def visit_Call(self, call: ast.Call) -> ast.AST:
                self.generic_visit(call)
                return _np("degrees", call) if _callee(call) in ANGLE_OUT else call
        yield "degrees", "the angle comes out in degrees: keep it in radians.", \
            lambda copy_: Wrap().visit(copy_) and None
    for step in STEPS:
        if step in shape.params:
            for factor, said in ((0.5, f"{step}/2"), (2.0, f"2{step}")):
                yield "step as given", f"the step {step} is used as {said}: use it exactly as given.", \
                    lambda copy_, step=step, factor=factor: copy_.body.insert(0, ast.Assign(
                        targets=[ast.Name(id=step, ctx=ast.Store())],
                        value=ast.BinOp(left=_name(step), op=ast.Mult(), right=ast.Constant(factor)), lineno=0))
    converted = [c for c in calls if _callee(c) in ("asarray", "array", "float") and
                 (any(k.arg == "dtype" for k in c.keywords) or _callee(c) == "float") and c.args and
                 isinstance(c.args[0], ast.Name) and c.args[0].id in shape.params]
    if converted:
        def integers(copy_: ast.FunctionDef) -> None:
            class Keep(ast.NodeTransformer):
                def visit_Call(self, call: ast.Call) -> ast.AST:
                    self.generic_visit(call)
                    if _callee(call) == "float" and call.args and isinstance(call.args[0], ast.Name) and \
                            call.args[0].id in shape.params:
                        return call.args[0]
                    call.keywords = [k for k in call.keywords if k.arg != "dtype"]
                    return call
            Keep().visit(copy_)
        first = converted[0].args[0].id
        yield "integer arithmetic", (f"integer arithmetic: with integer inputs your values stay integers; convert "
                                     f"{first} to float first (np.asarray({first}, dtype=float))."), integers
        vectors = [c.args[0].id for c in converted if _callee(c) == "asarray"]
        if shape.callables and vectors:
            def truncated(copy_: ast.FunctionDef) -> None:
                for f in sorted(shape.callables):
                    copy_.body.insert(0, ast.Assign(targets=[ast.Name(id=f, ctx=ast.Store())], lineno=0, value=ast.Call(
                        func=_name("__integer_points"), args=[_name(f), _name(vectors[0])], keywords=[])))
            p = vectors[0]
            yield "integer arithmetic", (f"integer arithmetic: with an integer {p} the points where you evaluate are "
                                         f"truncated to integers ({p} + h is {p} again); convert {p} to float first "
                                         f"(np.asarray({p}, dtype=float))."), truncated
    for i, p in enumerate(shape.params):
        for q in shape.params[i + 1:]:
            if {p, q} & (shape.callables | shape.sizes):
                continue
            def swapped(copy_: ast.FunctionDef, p=p, q=q) -> None:
                for arg in copy_.args.args + copy_.args.kwonlyargs:
                    arg.arg = {p: q, q: p}.get(arg.arg, arg.arg)
            yield "arguments swapped", f"{p} and {q} are swapped: the arguments are ({', '.join(shape.params)}).", \
                swapped
    yield from _new_for_old(shape)
    returns = [n for n in shape.nodes if isinstance(n, ast.Return) and n.value is not None]
    if returns:
        def wrapped(make: Callable[[ast.AST], ast.AST]) -> Callable[[ast.FunctionDef], None]:
            def change(copy_: ast.FunctionDef) -> None:
                for node in ast.walk(copy_):
                    if isinstance(node, ast.Return) and node.value is not None:
                        node.value = make(node.value)
            return change
        yield "power", "your value is the square of the right one: a power one too high.", \
            wrapped(lambda v: ast.BinOp(left=v, op=ast.Pow(), right=ast.Constant(2)))
        yield "factor 2", _scaled(("whole", 1), 2.0), wrapped(lambda v: ast.BinOp(left=ast.Constant(2.0), op=ast.Mult(),
                                                                                  right=v))
        yield "factor 2", _scaled(("whole", 1), 0.5), wrapped(lambda v: ast.BinOp(left=ast.Constant(0.5), op=ast.Mult(),
                                                                                  right=v))


def _new_for_old(shape: _Shape) -> Iterator[tuple[str, str, Callable[[ast.FunctionDef], None]]]:
    """The new state where the old one belongs: in a returned [x + ..., y + ..., th + omega dt], the other
    entries computed with th + omega dt for th."""
    for node in shape.nodes:
        if not (isinstance(node, ast.Return) and isinstance(node.value, ast.Call) and node.value.args and
                isinstance(node.value.args[0], ast.List)):
            continue
        entries = node.value.args[0].elts
        for k, entry in enumerate(entries):
            if not (isinstance(entry, ast.BinOp) and isinstance(entry.op, ast.Add) and isinstance(entry.left, ast.Name)):
                continue
            old = entry.left.id
            if not any(isinstance(n, ast.Name) and n.id == old for j, other in enumerate(entries) if j != k
                       for n in ast.walk(other)):
                continue

            def change(copy_: ast.FunctionDef, k=k, old=old) -> None:
                ret = next(n for n in ast.walk(copy_) if isinstance(n, ast.Return) and isinstance(n.value, ast.Call)
                           and n.value.args and isinstance(n.value.args[0], ast.List))
                items = ret.value.args[0].elts
                new = items[k]

                class Swap(ast.NodeTransformer):
                    def visit_Name(self, name: ast.Name) -> ast.AST:
                        return copy.deepcopy(new) if name.id == old and isinstance(name.ctx, ast.Load) else name
                items[:] = [item if j == k else Swap().visit(item) for j, item in enumerate(items)]
            yield "new state for old", (f"you move with the new {shape.alias.get(old, old)}, after the step, where "
                                        "the old one belongs: the step starts from the state as given."), change


# ------------------------------------------------------------------------------ building the mutants

def _integer_points(f: Callable, given: object) -> Callable:
    """`f` evaluated at points kept in the dtype of the vector as given (integers truncate x + h)."""
    dtype = np.asarray(given).dtype
    if dtype.kind not in "iu":
        return f
    return lambda point, *args, **kwargs: f(np.asarray(point).astype(dtype), *args, **kwargs)


def _fresh(source: str) -> ast.FunctionDef:
    """A new tree of the function `source` (parsing is much faster than copying a tree)."""
    return ast.parse(source).body[0]


def _replace(source: str, index: int, make: Callable[[ast.AST], ast.AST]) -> ast.FunctionDef:
    """A new tree of the function `source` with its `index`-th node (in ast.walk order) replaced by make(that node)."""
    mutated = _fresh(source)
    nodes = list(ast.walk(mutated))
    target = nodes[index]
    for parent in nodes:
        for field, value in ast.iter_fields(parent):
            if value is target:
                setattr(parent, field, make(target))
                return mutated
            if isinstance(value, list) and any(v is target for v in value):
                value[next(i for i, v in enumerate(value) if v is target)] = make(target)
                return mutated
    raise LookupError(index)


@functools.lru_cache(maxsize=None)
def mutants(chapter: str, function: str) -> tuple[Mutant, ...]:
    """Every single slip of the reference `function` of `chapter`, each once (Unavailable without the references)."""
    module = _module_of(chapter, function)
    original = ast.unparse(_definition(module, function))
    fdef = _fresh(original)  # the tree every copy is parsed to, node for node
    shape = _Shape(fdef)
    made: list[tuple[str, str, ast.FunctionDef]] = []
    for index, node in enumerate(shape.nodes):
        if node is fdef or not shape.mutable(node):
            continue
        for kind, said, make in _node_changes(shape, node):
            made.append((kind, said, _replace(original, index, make)))
    for kind, said, change in _function_changes(shape):
        mutated = _fresh(original)
        change(mutated)
        made.append((kind, said, mutated))
    out, seen = [], {original}
    namespace = dict(vars(module))
    namespace["__integer_points"] = _integer_points
    for kind, said, mutated in made:
        ast.fix_missing_locations(mutated)
        source = ast.unparse(mutated)
        if source in seen:
            continue
        seen.add(source)
        key = f"{function}#{len(out)}"
        scope = dict(namespace)
        try:
            exec(compile(ast.Module(body=[mutated], type_ignores=[]), f"<mutant {key}>", "exec"), scope)
        except Exception:  # noqa: BLE001  (a slip that does not even compile is no learner's)
            continue
        out.append(Mutant(key, kind, said, source, scope[fdef.name]))
    return tuple(out)


def every_source() -> Iterator[str]:
    """The source of every mutant of every public function of every chapter's reference solution: what a
    handout must never hold (grader.course.release's scan looks for them)."""
    for chapter, info in BY_ID.items():
        try:
            module = importlib.import_module(f"solutions.{info.module}")
        except ModuleNotFoundError:
            return
        for name, value in vars(module).items():
            if not name.startswith("_") and inspect.isfunction(value) and value.__module__ == module.__name__:
                yield from (mutant.source for mutant in mutants(chapter, name))


def standalone(mutant: Mutant) -> str:
    """The mutant as a learner's function would be written in the chapter's file, after the helper it uses, if
    any: for a corpus of one-slip submissions (benchmarks/misconceptions.py). Instructor side only."""
    if "__integer_points" not in mutant.source:
        return mutant.source
    helper = inspect.getsource(_integer_points).replace("def _integer_points(", "def __integer_points(", 1)
    return f"{helper}\n\n{mutant.source}"


def reference(chapter: str, function: str) -> Callable:
    """The unmutated reference `function` of `chapter`."""
    return getattr(_module_of(chapter, function), function)


def evaluate(function: Callable, args: tuple, kwargs: dict) -> object:
    """function(*args, **kwargs) with numpy's warnings silenced; None where it raises."""
    with quiet():
        return _evaluate(function, args, kwargs)


def _evaluate(function: Callable, args: tuple, kwargs: dict) -> object:
    try:
        return function(*args, **kwargs)
    except Exception:  # noqa: BLE001  (a slip that breaks on these inputs names nothing here)
        return None


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """numpy's and Python's warnings silenced (a slip divides by zero, takes the log of a negative number ...)."""
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        yield


def at_call(chapter: str, function: str, arguments: Callable[[], tuple[tuple, dict]],
            keys: set[str] | None = None) -> tuple[object, list]:
    """The reference's value at one call and [(mutant, value)] for every mutant (of `keys` only, if given) whose
    value there differs from it. `arguments()` gives fresh arguments (decoded as the learner's function gets
    them) for each evaluation."""
    out = []
    with quiet():
        right = _evaluate(reference(chapter, function), *arguments())
        for mutant in mutants(chapter, function):
            if keys is not None and mutant.key not in keys:
                continue
            value = _evaluate(mutant.function, *arguments())
            if value is not None and not same(value, right):
                out.append((mutant, value))
    return right, out


def arguments_of(call) -> Callable[[], tuple[tuple, dict]]:
    """Fresh arguments of a learner call (a grader.boundary.wire.Call), decoded as the learner's function gets
    them: catalogue callables, arrays of the given dtype, fresh Generators."""
    from grader.boundary.wire import decode_argument, encode_argument
    from grader.catalogue import CALLABLES

    args = [encode_argument(a) for a in call.args]  # as the child gets them; decoded afresh for every evaluation
    kwargs = [(k, encode_argument(v)) for k, v in call.kwargs]

    def arguments() -> tuple[tuple, dict]:
        return tuple(decode_argument(a, CALLABLES) for a in args), {k: decode_argument(v, CALLABLES) for k, v in kwargs}
    return arguments


def perturbed(call, rng: np.random.Generator):
    """The call with every real number (alone, or in a float vector or matrix) scaled by a random factor in
    [0.7, 1.3]: integers (sizes, seeds, integer points), callables and generators stay as they are."""
    from grader.boundary.wire import Array

    def move(arg: object) -> object:
        if isinstance(arg, (bool, int, str)) or arg is None:
            return arg
        if isinstance(arg, float):
            return arg * float(rng.uniform(0.7, 1.3))
        if isinstance(arg, Array):
            return Array(move(np.asarray(arg.values)), arg.dtype) if arg.dtype.startswith("float") else arg
        if isinstance(arg, np.ndarray):
            return arg * rng.uniform(0.7, 1.3, arg.shape) if arg.dtype.kind == "f" else arg
        if isinstance(arg, (tuple, list)):
            return type(arg)(move(a) for a in arg)
        return arg
    return type(call)(call.function, tuple(move(a) for a in call.args), tuple((k, move(v)) for k, v in call.kwargs))


def told_apart(chapter: str, mutant: Mutant, calls, rtol: float = 1e-6, atol: float = 1e-9) -> bool:
    """Whether the mutant's value differs from the reference's, beyond rtol and atol, at one of `calls` (Calls of
    its function) at least."""
    function = mutant.key.split("#")[0]
    for call in calls:
        arguments = arguments_of(call)
        right, value = evaluate(reference(chapter, function), *arguments()), evaluate(mutant.function, *arguments())
        if value is not None and not close(value, right, rtol, atol):
            return True
    return False


def close(a: object, b: object, rtol: float, atol: float) -> bool:
    """Values equal within rtol and atol, whatever their container (NaN equal to NaN)."""
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return len(a) == len(b) and all(close(x, y, rtol, atol) for x, y in zip(a, b))
    try:
        x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    except (TypeError, ValueError):
        return False
    with np.errstate(invalid="ignore"):
        return x.shape == y.shape and bool(np.all((x == y) | (np.abs(x - y) <= atol + rtol * np.abs(y)) |
                                                  (np.isnan(x) & np.isnan(y))))


def same(a: object, b: object) -> bool:
    """Equal values (to the last few bits), whatever their container."""
    return close(a, b, 1e-13, 0.0)
