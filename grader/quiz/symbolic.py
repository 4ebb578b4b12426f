"""Answers as expressions, read without eval of raw input.

Every answer is first read as people type it (`normalize`): the Unicode minus sign and en dash,
`×` and `·`, `÷`, `π`, `θ`, `√` and superscripts (`x²`, `r⁻²`) become their ASCII meaning, any
other non-ASCII character is refused, and implicit products are made explicit (`6x - 9`, `2xy`,
`2(x+1)`, `(x+1)(x-1)`, `r cos(theta)`), an identifier being split only into the question's own
symbols; `1/2x` and `x^2y` are refused as ambiguous (`1/2 x` and `x^2 y`, with the space, read as
(1/2)*x and x^2*y). Then it is parsed by Python's `ast` (after
`^` -> `**`) and checked against a whitelist of the syntax tree: numbers, the question's symbols
(and its derived symbols, such as `r` for sqrt(x^2 + y^2)), `pi` and `e`, + - * / ** and unary
signs, and calls with plain arguments to a fixed set of functions. Length is capped (on the text
as typed), and so are exponents: a power's exponent is a number of size at most MAX_EXPONENT
(`x^2`, `r^-2`, `(x^2+y^2)^(1/2)`), except for a power of `e`; powers of powers are refused.
Nothing else reaches sympy or the evaluator below.

Equivalence of two expressions: both are evaluated with plain floats (math module, no sympy) at
random points of the question's domain. Agreement at NUMERIC_POINTS points (at least
MIN_POINTS) means equal; a clear difference at one point where both sides are defined means not
equal (then simplify(a - b) cannot be 0 either). Only when too few points are defined does sympy
decide: parse_expr with exactly the allowed names, and simplify(a - b) == 0 within
SIMPLIFY_SECONDS, in a separate process that is killed when the time is up (Simplifier).
"Undecided" (a timeout, sympy's error) is never "equal". So sympy is imported only for those rare
answers, never in the grading process itself, and `grade` stays fast. Diagnoses (is the answer
this known wrong one?) are decided by the numbers alone (`decide=False`), never by sympy.
A derived symbol (`derived={"r": "sqrt(x^2 + y^2)"}`) takes, at each point, the value of its
definition there; for sympy it is replaced by its definition.
"""

from __future__ import annotations

import ast
import functools
import json
import keyword
import math
import operator
import random
import re
import subprocess
import sys
import time
from fractions import Fraction

MAX_LENGTH = 200
MAX_EXPONENT = 10
SIMPLIFY_SECONDS = 2.0
NUMERIC_POINTS = 12
MIN_POINTS = 8
RELATIVE_TOLERANCE = 1e-8
DEFAULT_DOMAIN = (0.5, 3.0)  # each symbol in +-[0.5, 3] unless the question gives its own range

# name -> (float implementation, accepted numbers of arguments)
FUNCTIONS: dict[str, tuple] = {
    "sqrt": (math.sqrt, (1,)), "sin": (math.sin, (1,)), "cos": (math.cos, (1,)), "tan": (math.tan, (1,)),
    "atan": (math.atan, (1,)), "atan2": (math.atan2, (2,)), "exp": (math.exp, (1,)),
    "log": (math.log, (1, 2)), "Abs": (abs, (1,)), "abs": (abs, (1,)),
}
CONSTANTS = {"pi": math.pi, "e": math.e}


class AnswerError(ValueError):
    """An answer that cannot be read; the message says why, in the learner's terms."""


class Undefined(ArithmeticError):
    """The expression has no real value at this point (outside its domain, overflow)."""


def _constant(node: ast.AST) -> Fraction | None:
    """The exact value of a number-only expression (+ - * / and signs), None if it has names or calls."""
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        try:
            return Fraction(node.value)
        except (OverflowError, ValueError):  # inf, nan
            raise AnswerError("numbers must be finite") from None
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        value = _constant(node.operand)
        return None if value is None else (-value if isinstance(node.op, ast.USub) else value)
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub, ast.Mult, ast.Div)):
        left, right = _constant(node.left), _constant(node.right)
        if left is None or right is None:
            return None
        if isinstance(node.op, ast.Add):
            return left + right
        if isinstance(node.op, ast.Sub):
            return left - right
        if isinstance(node.op, ast.Mult):
            return left * right
        if right == 0:
            raise AnswerError("division by zero")
        return left / right
    return None


def _has_power(node: ast.AST) -> bool:
    return any(isinstance(n, ast.BinOp) and isinstance(n.op, ast.Pow) for n in ast.walk(node))


def _check_power(node: ast.BinOp, symbols: tuple[str, ...]) -> None:
    if isinstance(node.left, ast.BinOp) and isinstance(node.left.op, ast.Pow):
        raise AnswerError("a power of a power is not allowed; write it out with brackets and one ^")
    if isinstance(node.left, ast.Name) and node.left.id == "e" and "e" not in symbols:
        return  # e^(anything allowed): stays exp(...) in sympy, overflows harmlessly as a float
    if _has_power(node.right):
        raise AnswerError("a power of a power is not allowed; write it out with brackets and one ^")
    exponent = _constant(node.right)
    if exponent is None:
        raise AnswerError("an exponent must be a number such as 2, -1 or 1/2 (write exp(x) or e^x "
                          "for a power of e)")
    if abs(exponent) > MAX_EXPONENT:
        raise AnswerError(f"exponents above {MAX_EXPONENT} in size are not allowed")


def _check_tree(tree: ast.AST, symbols: tuple[str, ...], lists: bool) -> None:
    allowed_names = set(symbols) | set(CONSTANTS)
    for node in ast.walk(tree):
        if lists and isinstance(node, (ast.List, ast.Tuple)):
            continue
        if isinstance(node, (ast.Expression, ast.Load)):
            continue
        if isinstance(node, ast.operator):
            if not isinstance(node, (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)):
                raise AnswerError(f"the operator {type(node).__name__} is not allowed (use + - * / ^)")
            continue
        if isinstance(node, ast.unaryop):
            if not isinstance(node, (ast.USub, ast.UAdd)):
                raise AnswerError("only a leading minus or plus sign is allowed")
            continue
        if isinstance(node, ast.BinOp):
            if isinstance(node.op, ast.Pow):
                _check_power(node, symbols)
            continue
        if isinstance(node, ast.UnaryOp):
            continue
        if isinstance(node, ast.Constant):
            if type(node.value) not in (int, float):
                raise AnswerError("only numbers and the question's symbols are allowed (no strings)")
            if not math.isfinite(node.value):
                raise AnswerError("numbers must be finite")
            continue
        if isinstance(node, ast.Name):
            if node.id not in allowed_names and node.id not in FUNCTIONS:
                raise AnswerError(_unknown_name(node.id, ", ".join(symbols) or "none", allowed_names))
            continue
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
                raise AnswerError(f"only these functions may be called: {', '.join(FUNCTIONS)}")
            if node.keywords:
                raise AnswerError("function calls take plain arguments only")
            arities = FUNCTIONS[node.func.id][1]
            if len(node.args) not in arities:
                wanted = " or ".join(map(str, arities))
                raise AnswerError(f"{node.func.id} takes {wanted} argument(s), got {len(node.args)}")
            continue
        raise AnswerError(f"{type(node).__name__} is not allowed in an answer")
    called = {id(node.func) for node in ast.walk(tree) if isinstance(node, ast.Call)}
    for node in ast.walk(tree):  # a bare function name used as a value, e.g. "sqrt + 1"
        if isinstance(node, ast.Name) and node.id in FUNCTIONS and id(node) not in called \
                and node.id not in allowed_names:
            raise AnswerError(f"{node.id} is a function: write {node.id}(...)")


# What people type for plain ASCII: the minus sign and the en dash, times and dots, division, a
# no-break space, pi, theta and the root sign (superscripts: _SUPERSCRIPTS). Nothing else non-ASCII.
_TYPED = {"\u2212": "-", "\u2013": "-", "\u00d7": "*", "\u00b7": "*", "\u22c5": "*", "\u2219": "*",
          "\u00f7": "/", "\u00a0": " ", "\u03c0": "pi", "\u03b8": "theta"}
_SUPERSCRIPTS = dict(zip("\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079\u207b\u207a", "0123456789-+"))
_ROOT = re.compile("\u221a\\s*(\\d+(?:\\.\\d*)?|[A-Za-z_]\\w*+(?!\\s*\\())", re.A)
_TOKEN = re.compile(r"(\s*)(?:(\d+\.?\d*(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)|([A-Za-z_]\w*)"
                    "|([\u2070\u00b9\u00b2\u00b3\u2074-\u2079\u207a\u207b]+)|(\\*\\*|.))", re.S | re.A)
_NAME_AND_DIGITS = re.compile(r"([A-Za-z]+)(\d+)", re.A)


def _ascii(text: str) -> str:
    """`text` with what people type for plain ASCII replaced (superscripts stay for _tokens);
    AnswerError for any other non-ASCII character."""
    text = _ROOT.sub(r"sqrt(\1)", text).replace("\u221a", "sqrt")
    text = "".join(_TYPED.get(ch, ch) for ch in text)
    bad = next((ch for ch in text if not ch.isascii() and ch not in _SUPERSCRIPTS), None)
    if bad is not None:
        raise AnswerError(f"the character {bad!r} (U+{ord(bad):04X}) is not plain ASCII; type it with the keyboard "
                          "(e.g. x for the letter x, sqrt(...) for a root, ^ for a power)")
    return text


def _split(word: str, names: set[str], call: bool) -> list[str] | None:
    """`word` as a product of allowed names (`xy` -> x, y; `vdt` -> v, dt), the last one possibly a
    function when `call` (`rcos(` -> r, cos); None unless there is exactly one way."""
    if not word.isalpha():
        return None
    ways: list[list[str]] = []

    def walk(rest: str, parts: list[str]) -> None:
        if len(ways) > 1:
            return
        if not rest:
            ways.append(parts)
            return
        for size in range(1, len(rest) + 1):
            head = rest[:size]
            if head in names or (call and size == len(rest) and head in FUNCTIONS and parts):
                walk(rest[size:], parts + [head])

    walk(word, [])
    return ways[0] if len(ways) == 1 and len(ways[0]) > 1 else None


def _factor_start(tokens: list[list[str]], i: int) -> int:
    """The index of the first token of the factor that ends at token i (a number, name, call,
    bracket or power by superscript)."""
    kind = tokens[i][1]
    if kind == "sup" and i > 0:
        return _factor_start(tokens, i - 1)
    if tokens[i][2] == ")":
        depth = 0
        for j in range(i, -1, -1):
            depth += {")": 1, "(": -1}.get(tokens[j][2], 0) if tokens[j][1] == "op" else 0
            if depth == 0:
                return j - 1 if j > 0 and tokens[j - 1][1] == "name" else j
    return i


def _implicit(left: list[str], right: list[str], names: set[str]) -> bool:
    """Whether two neighbouring tokens multiply: `2 x`, `2(`, `x y`, `x(`, `)(`, `)x`, `x² y` (no
    keyword on either side, no function name on the left)."""
    if right[1] == "name":
        if keyword.iskeyword(right[2]):
            return False
    elif right[2] != "(" or right[1] != "op":
        return False
    if left[1] in ("num", "sup") or (left[1] == "op" and left[2] == ")"):
        return True
    if left[1] != "name" or keyword.iskeyword(left[2]) or left[2] in FUNCTIONS:
        return False
    # a symbol times anything; an unknown name only times a name (`x2 y`: the whitelist names x2),
    # never before a bracket, which keeps `__import__('os')` a call the whitelist refuses as one
    return left[2] in names or right[1] == "name"


def normalize(text: object, symbols: tuple[str, ...] = ()) -> str:
    """An answer as typed, in Python's syntax: Unicode read as ASCII, superscripts as powers,
    implicit products made explicit, `^` as `**`. AnswerError for what cannot be read so, with
    how to write it. Checks nothing else: check_text does."""
    if not isinstance(text, str):
        text = str(text)
    if len(text) > MAX_LENGTH:
        raise AnswerError(f"the answer is {len(text)} characters long; at most {MAX_LENGTH} are read")
    text = _ascii(text)
    names = set(symbols) | set(CONSTANTS)
    tokens: list[list[str]] = []
    matches = list(_TOKEN.finditer(text))
    for index, match in enumerate(matches):
        space, num, name, sup, op = match.groups()
        if sup is not None:
            tokens.append([space, "sup", "**(" + "".join(_SUPERSCRIPTS[ch] for ch in sup) + ")"])
            continue
        if name is not None and name not in names and name not in FUNCTIONS and not keyword.iskeyword(name):
            after = matches[index + 1].group(5) if index + 1 < len(matches) else None
            parts = _split(name, names, call=after == "(")
            if parts:
                tokens.append([space, "name", parts[0]])
                tokens.extend(["", "name", part] for part in parts[1:])
                continue
        kind = "num" if num is not None else "name" if name is not None else "op"
        tokens.append([space, kind, num or name or op or ""])
    tokens = _bare_arguments(tokens, names)
    out = []
    for i, token in enumerate(tokens):
        if i and _implicit(tokens[i - 1], token, names):
            start = _factor_start(tokens, i - 1)
            before = tokens[start - 1] if start > 0 else None
            bare = start == i - 1 and tokens[i - 1][1] in ("num", "name")
            spaced = bool(token[0])  # `x^2 y`, `1/2 x`: the space says where the factor ends
            if before is not None and before[1] == "op" and not spaced and \
                    (before[2] == "/" or before[2] in ("^", "**") and bare):
                raise AnswerError(_ambiguous(tokens, start, i))
            out.append("*")
        out.append(token[0] + token[2])
    return "".join(out).replace("^", "**").strip()


def _bare_arguments(tokens: list[list[str]], names: set[str]) -> list[list[str]]:
    """`cos y` and `sin 2` as cos(y) and sin(2): a function name followed by one symbol or number
    and then by nothing or an operator; AnswerError for `sin x^2` (sin(x^2) or sin(x)^2?) and
    `sin 2x` (sin(2x) or sin(2)x?)."""
    out: list[list[str]] = []
    i = 0
    while i < len(tokens):
        token = tokens[i]
        argument = tokens[i + 1] if i + 1 < len(tokens) else None
        if token[1] == "name" and token[2] in FUNCTIONS and token[2] not in names and argument is not None and \
                (argument[1] == "num" or argument[1] == "name" and argument[2] in names):
            after = tokens[i + 2] if i + 2 < len(tokens) else None
            if after is not None and (after[1] != "op" or after[2] in ("^", "**", "(")):
                end = i + (4 if after[2] in ("^", "**") else 3)
                shown = "".join(t[0] + t[2] for t in tokens[i:end]).replace("**", "^").strip()
                raise AnswerError(f"put the argument of {token[2]} in brackets: `{shown}` can be read more "
                                  f"than one way")
            out += [token, ["", "op", "("], argument, ["", "op", ")"]]
            i += 2
            continue
        out.append(token)
        i += 1
    return out


def _ambiguous(tokens: list[list[str]], start: int, i: int) -> str:
    """Why `1/2x` (or `x^2y`) cannot be read: the implicit product at token i follows the factor
    that starts at `start`, right after a / or ^; the two readings, written out."""
    def text(part: list[list[str]]) -> str:
        return "".join(t[0] + t[2] for t in part).replace("**", "^").strip()

    operator = "/" if tokens[start - 1][2] == "/" else "^"
    before = text(tokens[_factor_start(tokens, start - 2):start - 1]) if start >= 2 else ""
    factor = text(tokens[start:i])
    right = tokens[i][2] if tokens[i][1] == "name" else "(...)"
    if operator == "/":
        readings = f"{before}/({factor}*{right}) or ({before}/{factor})*{right}"
    else:
        readings = f"{before}^{factor}*{right} or {before}^({factor}*{right})"
    return f"`{before}{operator}{factor}{right}` is ambiguous: write {readings}"


def _unknown_name(name: str, allowed: str, names: set[str]) -> str:
    message = f"unknown name {name!r} (symbols allowed here: {allowed})"
    digits = _NAME_AND_DIGITS.fullmatch(name)
    if digits and digits.group(1) in names:
        base, power = digits.groups()
        return f"{message}; write {base}^{power} for a power or {power}*{base} for a product"
    for function in FUNCTIONS:
        if name.startswith(function) and name[len(function):] in names:
            return f"{message}; write {function}({name[len(function):]})"
    return message


def check_text(text: object, symbols: tuple[str, ...] = (), lists: bool = False) -> ast.Expression:
    """Whitelist-check an answer's syntax tree (with `lists`, brackets of numbers too), after
    `normalize`; the tree, or AnswerError. Needs neither sympy nor any evaluation. The tree of a text
    is checked once per process and shared: callers read it and never change it."""
    if isinstance(text, str):
        return _checked_tree(text, tuple(symbols), lists)
    return _checked_tree.__wrapped__(text, tuple(symbols), lists)


@functools.lru_cache(maxsize=4096)  # a class's answers and a key's wrong versions repeat across learners
def _checked_tree(text: object, symbols: tuple[str, ...], lists: bool) -> ast.Expression:
    text = normalize(text, symbols)
    if not text:
        raise AnswerError("the answer is empty")
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise AnswerError(f"cannot read it as a formula ({exc.msg})") from None
    except (ValueError, RecursionError, MemoryError):  # e.g. a NUL byte, absurd nesting
        raise AnswerError("cannot read it as a formula") from None
    _check_tree(tree, symbols, lists)
    return tree


def evaluate(node: ast.AST, values: dict[str, float]) -> float:
    """A checked tree's value as a float at `values` (symbol -> number); Undefined where it has none. The tree is
    made into nested functions (_evaluator), which compute what walking it would, operation by operation in the same
    order; those of the trees evaluated last are kept (an equivalence check evaluates its two at many points)."""
    kept = _EVALUATORS.get(id(node))
    if kept is None or kept[0] is not node:
        kept = (node, _evaluator(node))
        if len(_EVALUATORS) >= _EVALUATORS_MAX:
            _EVALUATORS.clear()  # a class's trees are many and each is used at once: memory stays flat
        _EVALUATORS[id(node)] = kept
    return kept[1](values)


_EVALUATORS: dict[int, tuple[ast.AST, object]] = {}  # id of a tree -> (the tree, kept alive: its id stays its, evaluator)
_EVALUATORS_MAX = 256


def _evaluator(node: ast.AST):
    """A function of `values` giving `node`'s value as evaluate() defines it: a constant's or a name's as it is, an
    operation's a finite real float, or Undefined (division by zero, too large, outside a function's domain, not a
    finite real number, or a node that has no value: the whitelist lets none through)."""
    if isinstance(node, ast.Expression):
        return _evaluator(node.body)
    if isinstance(node, ast.Constant):
        constant = node.value
        try:
            value = float(constant)
        except (OverflowError, ValueError, TypeError):  # raised where it is evaluated, as float() raises it
            return lambda values: float(constant)
        return lambda values: value
    if isinstance(node, ast.Name):
        name = node.id
        return lambda values: values[name] if name in values else CONSTANTS[name]
    if isinstance(node, ast.UnaryOp):
        operand = _evaluator(node.operand)
        compute = (lambda values: -operand(values)) if isinstance(node.op, ast.USub) else operand
    elif isinstance(node, ast.BinOp):
        left, right = _evaluator(node.left), _evaluator(node.right)
        operation = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
                     ast.Div: operator.truediv}.get(type(node.op), operator.pow)

        def compute(values: dict[str, float]) -> object:
            return operation(left(values), right(values))
    elif isinstance(node, ast.Call):
        function = FUNCTIONS[node.func.id][0]
        arguments = [_evaluator(arg) for arg in node.args]

        def compute(values: dict[str, float]) -> object:
            return function(*[argument(values) for argument in arguments])
    else:
        kind = type(node).__name__

        def compute(values: dict[str, float]) -> object:
            raise AnswerError(f"{kind} has no value")

    def checked(values: dict[str, float]) -> float:
        try:
            result = compute(values)
        except ZeroDivisionError:
            raise Undefined("division by zero") from None
        except OverflowError:
            raise Undefined("too large") from None
        except ValueError:
            raise Undefined("outside a function's domain, e.g. sqrt or log of a negative number") from None
        if isinstance(result, complex) or not math.isfinite(result):
            raise Undefined("not a finite real number")
        return float(result)

    return checked


def number(text: object) -> float:
    """A numeric answer: 0.6, '0.6', '3/5', '-1e-5', 'sqrt(3)/2', '2*pi'; AnswerError otherwise."""
    if isinstance(text, bool) or text is None:
        raise AnswerError(f"expected a number, got {text!r}")
    if isinstance(text, (int, float)):
        if not math.isfinite(text):
            raise AnswerError("expected a finite number")
        return float(text)
    tree = check_text(str(text).strip(), ())
    try:
        return evaluate(tree, {})
    except Undefined as exc:
        raise AnswerError(f"it has no finite real value ({exc})") from None


def _with_numbers(node: object, values: dict[str, float]) -> object:
    """A copy of a checked tree with the names of `values` replaced by their numbers (a negative one as a
    minus sign and a number); the tree itself stays as it is (check_text shares it)."""
    if isinstance(node, ast.Name) and node.id in values:
        value = float(values[node.id])
        size = ast.Constant(int(abs(value)) if value.is_integer() else abs(value))
        return ast.UnaryOp(ast.USub(), size) if value < 0 else size
    if isinstance(node, ast.AST):
        return type(node)(**{name: _with_numbers(field, values) for name, field in ast.iter_fields(node)})
    if isinstance(node, list):
        return [_with_numbers(item, values) for item in node]
    return node


def substitute(text: str, values: dict[str, float], symbols: tuple[str, ...] = ()) -> str:
    """`text`, an expression in `symbols` and the names of `values` (a per-learner key: the question's
    parameters), with each of those names replaced by its number: one learner's expression, in
    `symbols` alone. AnswerError if `text` does not pass the whitelist with those names."""
    if not values:
        return text
    return _substituted(text, tuple(values.items()), tuple(symbols))


@functools.lru_cache(maxsize=4096)
def _substituted(text: str, values: tuple[tuple[str, float], ...], symbols: tuple[str, ...]) -> str:
    numbers = dict(values)
    tree = _with_numbers(check_text(text, symbols + tuple(numbers)), numbers)
    written = ast.unparse(ast.fix_missing_locations(tree))
    return written.replace(" ** ", "^").replace(" * ", "*").replace(" / ", "/")


def parse(text: str, symbols: tuple[str, ...] = (), derived: dict[str, str] | None = None):
    """The answer as a sympy expression, after the whitelist check: parse_expr with a dictionary of
    exactly the allowed symbols, functions and constants, and no other name (no auto-symbols); a
    derived symbol stands for its definition (itself parsed in `symbols`)."""
    derived = derived or {}
    check_text(text, symbols + tuple(derived))
    import sympy
    from sympy.parsing.sympy_parser import auto_number, parse_expr

    names = {"sqrt": sympy.sqrt, "sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan, "atan": sympy.atan,
             "atan2": sympy.atan2, "exp": sympy.exp, "log": sympy.log, "Abs": sympy.Abs, "abs": sympy.Abs,
             "pi": sympy.pi, "e": sympy.E}
    names.update({name: sympy.Symbol(name, real=True) for name in symbols})
    names.update({name: parse(definition, symbols) for name, definition in derived.items()})
    global_names = {"Integer": sympy.Integer, "Float": sympy.Float, "Rational": sympy.Rational,
                    "__builtins__": {}}
    try:
        return parse_expr(normalize(text, symbols + tuple(derived)), local_dict=names, global_dict=global_names,
                          transformations=(auto_number,), evaluate=True)
    except Exception as exc:  # noqa: BLE001  sympy's own errors on a whitelisted tree: report, never crash
        raise AnswerError(f"cannot read it as a formula ({type(exc).__name__})") from None


class Simplifier:
    """sympy's simplify in a separate process, where it can be stopped.

    sympy's simplify on an allowed but hostile expression (exp(exp(exp(exp(exp(100)))))) runs for many
    seconds in C-level big-number code that no thread can interrupt. So it runs in a child
    interpreter of its own, started on first use (importing sympy there does not count against
    SIMPLIFY_SECONDS), with CPU-time and memory limits (resource.setrlimit where the platform has
    it), and killed with its process group (grader.helpers.stop_helper) when an answer takes longer than SIMPLIFY_SECONDS or the
    learner's `deadline` (a time.monotonic() value) passes (then `out_of_time`). After a kill every
    further question to this Simplifier is undecided at once. Use it as a context manager: the process
    ends with the block."""

    def __init__(self, deadline: float | None = None) -> None:
        self.deadline = deadline
        self.process: subprocess.Popen | None = None
        self.stopped = False
        self.out_of_time = False  # stopped because the learner's deadline came first
        self._buffer = b""
        self._reader = None  # a grader.system.StreamReader on the worker's output

    def __enter__(self) -> Simplifier:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def _wait(self, seconds: float) -> bytes | None:
        """The worker's next line within `seconds` and before the deadline; None if none came."""
        limit = time.monotonic() + seconds
        until = limit if self.deadline is None else min(limit, self.deadline)
        line = self._line(until)
        if line is None and until < limit:
            self.out_of_time = True
        return line or None

    def _start(self) -> bool:
        from grader.helpers import start_helper
        from grader.system import StreamReader, child_path

        # no -I/-E: the environment is grader.system's child_environment (no PYTHONPATH), and its PYTHONHASHSEED=0 makes
        # sympy's term order, and so its verdict, the same on every run
        try:
            self.process = start_helper([sys.executable, "-S", "-c", _WORKER_BOOT.format(child_path())])
        except OSError:
            return False
        self._reader = StreamReader(self.process.stdout)
        return self._wait(SYMPY_START_SECONDS) == b"ready"

    def _line(self, until: float) -> bytes | None:
        """The worker's next line; None if none came by `until`, b"" if the worker ended."""
        while b"\n" not in self._buffer:
            try:
                chunk = self._reader.read(until - time.monotonic())
            except TimeoutError:
                return None
            if not chunk:
                return b""
            self._buffer += chunk
        line, self._buffer = self._buffer.split(b"\n", 1)
        return line.strip() or b"?"

    def is_zero(self, answer: str, key: str, symbols: tuple[str, ...],
                derived: dict[str, str] | None = None) -> bool | None:
        """Whether simplify(answer - key) == 0; None when sympy could not decide it in time (or failed)."""
        if self.stopped:
            return None
        if self.process is None and not self._start():
            self._stop()
            return None
        job = json.dumps({"answer": answer, "key": key, "symbols": list(symbols),
                          "derived": derived or {}}).encode() + b"\n"
        try:
            self.process.stdin.write(job)
        except OSError:
            self._stop()
            return None
        verdict = self._wait(SIMPLIFY_SECONDS)
        if verdict not in (b"true", b"false", b"error"):
            self._stop()
            return None
        return None if verdict == b"error" else verdict == b"true"

    def _stop(self) -> None:
        self.close()
        self.stopped = True

    def close(self) -> None:
        """Kill the worker and everything it started."""
        if self.process is None:
            return
        from grader.helpers import stop_helper

        stop_helper(self.process)
        self.process = None


SYMPY_START_SECONDS = 30.0  # a fresh interpreter importing sympy (about 0.4 s; more on a loaded machine)
SYMPY_CPU_SECONDS = 60  # a backstop: the worker is killed at its wall-clock time limits anyway
SYMPY_MEMORY_BYTES = 2 << 30
_WORKER_BOOT = "import sys; sys.path[:] = {!r}; from grader.quiz.symbolic import _worker; _worker()  # grader-sympy"


def _worker() -> None:
    """The Simplifier's process: limit itself, import sympy, say 'ready', then answer one job a line
    (true, false, or error when sympy fails) until its input ends."""
    try:
        import resource

        for limit, value in ((resource.RLIMIT_CPU, SYMPY_CPU_SECONDS), (resource.RLIMIT_AS, SYMPY_MEMORY_BYTES),
                             (resource.RLIMIT_CORE, 0)):
            try:
                resource.setrlimit(limit, (value, value))
            except (ValueError, OSError):
                pass
    except ImportError:  # not on this platform: the wall-clock kill still holds
        pass
    import sympy

    out = sys.stdout.buffer
    out.write(b"ready\n")
    out.flush()
    for line in iter(sys.stdin.buffer.readline, b""):
        try:
            job = json.loads(line)
            symbols, derived = tuple(job["symbols"]), job.get("derived") or {}
            same = bool(sympy.simplify(parse(job["answer"], symbols, derived) - parse(job["key"], symbols, derived)) == 0)
            out.write(b"true\n" if same else b"false\n")
        except Exception:  # noqa: BLE001  sympy's failure to decide is never "equal"
            out.write(b"error\n")
        out.flush()


def _simplify_is_zero(answer: str, key: str, symbols: tuple[str, ...], deadline: float | None = None,
                      derived: dict[str, str] | None = None) -> bool | None:
    """simplify(answer - key) == 0 in a Simplifier of its own; None if undecided in time."""
    with Simplifier(deadline) as simplifier:
        return simplifier.is_zero(answer, key, symbols, derived)


@functools.lru_cache(maxsize=256)
def _points(symbols: tuple[str, ...], domain: tuple[tuple[str, tuple[float, float]], ...],
            seed: int) -> tuple[dict[str, float], ...]:
    """The NUMERIC_POINTS * 4 random points `_pairs` tries (the same for the same symbols, domain and seed;
    callers copy a point before adding to it)."""
    ranges = dict(domain)
    draw = random.Random(seed)
    points = []
    for _ in range(NUMERIC_POINTS * 4):
        point = {}
        for name in symbols:
            if name in ranges:
                point[name] = draw.uniform(*ranges[name])
            else:
                point[name] = draw.choice((-1, 1)) * draw.uniform(*DEFAULT_DOMAIN)
        points.append(point)
    return tuple(points)


def _pairs(answer: str, key: str, symbols: tuple[str, ...], domain: dict[str, tuple[float, float]] | None,
           seed: int, derived: dict[str, str] | None, bound: dict[str, float] | None = None):
    """(answer, key) values at up to NUMERIC_POINTS * 4 random points of the domain where both are
    defined (and every derived symbol is). `bound` names have the same value at every point (a per-learner
    key's parameters: the same values as substitute writes in). AnswerError if `answer` cannot be read."""
    derived = derived or {}
    bound = bound or {}
    names = symbols + tuple(derived) + tuple(bound)
    answer_tree = check_text(answer, names)
    key_tree = check_text(key, names)
    definitions = {name: check_text(text, symbols) for name, text in derived.items()}
    ranges = tuple(sorted((name, tuple(span)) for name, span in (domain or {}).items()))
    for drawn in _points(tuple(symbols), ranges, seed):
        point = dict(drawn)
        try:
            for name, tree in definitions.items():
                point[name] = evaluate(tree, point)
            point.update((name, float(value)) for name, value in bound.items())
            yield evaluate(answer_tree, point), evaluate(key_tree, point)
        except Undefined:
            continue


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= RELATIVE_TOLERANCE * max(1.0, abs(a), abs(b))


def equivalent(answer: str, key: str, symbols: tuple[str, ...],
               domain: dict[str, tuple[float, float]] | None = None, seed: int = 0,
               simplifier: Simplifier | None = None, derived: dict[str, str] | None = None,
               decide: bool = True, bound: dict[str, float] | None = None) -> bool | None:
    """Whether two expression texts are the same function of `symbols` (see the module docstring):
    True or False, or None when sympy had to decide and could not in time (never "equal").
    `domain` maps a symbol to its (low, high) range; others are drawn from +-DEFAULT_DOMAIN.
    `derived` maps a derived symbol to its definition in `symbols`.
    `simplifier` is the Simplifier to ask if sympy must decide (else one of its own); with
    `decide=False` sympy is never asked, and what the numbers cannot decide is None. `bound` names
    stand for their numbers in both expressions (for sympy, they are written in: substitute).
    AnswerError if `answer` cannot be read."""
    agree = 0
    for a, k in _pairs(answer, key, symbols, domain, seed, derived, bound):
        if not _close(a, k):
            return False  # a point where both are defined and differ: not the same function
        agree += 1
        if agree >= NUMERIC_POINTS:
            return True
    if agree >= MIN_POINTS:
        return True
    if not decide:
        return None
    if bound:
        names = symbols + tuple(derived or {})
        answer, key = substitute(answer, bound, names), substitute(key, bound, names)
    if simplifier is not None:
        return simplifier.is_zero(answer, key, symbols, derived)
    return _simplify_is_zero(answer, key, symbols, derived=derived)


def ratio(answer: str, key: str, symbols: tuple[str, ...], domain: dict[str, tuple[float, float]] | None = None,
          seed: int = 0, derived: dict[str, str] | None = None) -> float | None:
    """The constant c with answer = c * key at every point the numbers try (at least MIN_POINTS
    where the key is not 0), or None; decided by the numbers alone."""
    found, agree = None, 0
    for a, k in _pairs(answer, key, symbols, domain, seed, derived):
        if abs(k) < 1e-9:
            continue
        if found is None:
            found = a / k
        elif not _close(a, found * k):
            return None
        agree += 1
    return found if agree >= MIN_POINTS else None
