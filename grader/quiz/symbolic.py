"""Answers as expressions, parsed without eval of raw input.

Every answer is first parsed by Python's `ast` and checked against a whitelist of the syntax
tree (numbers, the question's symbols, + - * / ** and unary minus, calls to a fixed set of
functions); only then is it handed to sympy, with a dictionary of exactly those names. Length,
exponent size and simplification time are capped. Equivalence: simplify(a - b) == 0, else
agreement at random points of the question's domain; "undecided" is never "equal".
"""

from __future__ import annotations

import ast
import random
import threading

MAX_LENGTH = 200
MAX_EXPONENT = 10
SIMPLIFY_SECONDS = 2.0
NUMERIC_POINTS = 12
FUNCTIONS = ("sqrt", "sin", "cos", "tan", "atan", "atan2", "exp", "log", "Abs", "abs")
CONSTANTS = ("pi", "e")


class AnswerError(ValueError):
    """An answer that cannot be read; the message says why, in the learner's terms."""


def _check_tree(tree: ast.AST, symbols: tuple[str, ...], lists: bool) -> None:
    allowed_names = set(symbols) | set(CONSTANTS)
    for node in ast.walk(tree):
        if lists and isinstance(node, (ast.List, ast.Tuple)):
            continue
        if isinstance(node, (ast.Expression, ast.Load, ast.operator, ast.unaryop)):
            if isinstance(node, ast.operator) and not isinstance(node, (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)):
                raise AnswerError(f"the operator {type(node).__name__} is not allowed (use + - * / ^)")
            if isinstance(node, ast.unaryop) and not isinstance(node, (ast.USub, ast.UAdd)):
                raise AnswerError("only a leading minus or plus sign is allowed")
            continue
        if isinstance(node, ast.BinOp):
            if isinstance(node.op, ast.Pow):
                exponent = node.right
                if isinstance(exponent, ast.UnaryOp) and isinstance(exponent.operand, ast.Constant):
                    exponent = exponent.operand
                if isinstance(node.left, ast.BinOp) and isinstance(node.left.op, ast.Pow) or \
                        isinstance(node.right, ast.BinOp) and isinstance(node.right.op, ast.Pow):
                    raise AnswerError("a power of a power is not allowed; write it out with brackets and one ^")
                if isinstance(exponent, ast.Constant) and abs(exponent.value) > MAX_EXPONENT:
                    raise AnswerError(f"exponents above {MAX_EXPONENT} are not allowed")
            continue
        if isinstance(node, ast.UnaryOp):
            continue
        if isinstance(node, ast.Constant):
            if type(node.value) not in (int, float):
                raise AnswerError("only numbers and the question's symbols are allowed (no strings)")
            continue
        if isinstance(node, ast.Name):
            if node.id not in allowed_names and node.id not in FUNCTIONS:
                allowed = ", ".join(symbols) or "none"
                raise AnswerError(f"unknown name {node.id!r} (symbols allowed here: {allowed})")
            continue
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
                raise AnswerError(f"only these functions may be called: {', '.join(FUNCTIONS)}")
            if node.keywords:
                raise AnswerError("function calls take plain arguments only")
            continue
        raise AnswerError(f"{type(node).__name__} is not allowed in an answer")


def check_text(text: str, symbols: tuple[str, ...] = (), lists: bool = False) -> ast.Expression:
    """Whitelist-check an answer's syntax tree (with `lists`, brackets of numbers too); the tree,
    or AnswerError."""
    if not isinstance(text, str):
        text = str(text)
    if len(text) > MAX_LENGTH:
        raise AnswerError(f"the answer is {len(text)} characters long; at most {MAX_LENGTH} are read")
    if not text.isascii():
        bad = next(ch for ch in text if not ch.isascii())
        raise AnswerError(f"the character {bad!r} (U+{ord(bad):04X}) is not plain ASCII; type it with the keyboard "
                          "(e.g. - for a minus sign, x for the letter x)")
    if not text.strip():
        raise AnswerError("the answer is empty")
    source = text.replace("^", "**")
    try:
        tree = ast.parse(source.strip(), mode="eval")
    except SyntaxError as exc:
        raise AnswerError(f"cannot read it as a formula ({exc.msg})") from None
    _check_tree(tree, symbols, lists)
    return tree


def parse(text: str, symbols: tuple[str, ...] = ()):
    """The answer as a sympy expression, after the whitelist check."""
    check_text(text, symbols)
    import sympy

    names = {name: sympy.Symbol(name, real=True) for name in symbols}
    names.update(sqrt=sympy.sqrt, sin=sympy.sin, cos=sympy.cos, tan=sympy.tan, atan=sympy.atan,
                 atan2=sympy.atan2, exp=sympy.exp, log=sympy.log, Abs=sympy.Abs, abs=sympy.Abs,
                 pi=sympy.pi, e=sympy.E)
    from sympy.parsing.sympy_parser import auto_number, parse_expr

    global_names = {"Integer": sympy.Integer, "Float": sympy.Float, "Rational": sympy.Rational,
                    "__builtins__": {}}
    try:
        return parse_expr(text.replace("^", "**"), local_dict=names, global_dict=global_names,
                          transformations=(auto_number,), evaluate=True)
    except Exception as exc:  # sympy's own errors on a whitelisted tree: report, never crash
        raise AnswerError(f"cannot read it as a formula ({type(exc).__name__})") from None


def number(text: object) -> float:
    """A numeric answer: '0.6', '3/5', '-1e-5', 'sqrt(3)/2'; AnswerError otherwise."""
    if isinstance(text, bool):
        raise AnswerError("expected a number, got true/false")
    if isinstance(text, (int, float)):
        return float(text)
    text = str(text).strip()
    try:
        return float(text)
    except ValueError:
        pass
    from fractions import Fraction

    try:
        return float(Fraction(text.replace(" ", "")))
    except (ValueError, ZeroDivisionError):
        pass
    value = parse(text, ())
    try:
        result = complex(value.evalf())
    except (TypeError, ValueError):
        raise AnswerError("cannot read it as a number") from None
    if result.imag != 0:
        raise AnswerError("expected a real number")
    return result.real


def _simplify_is_zero(difference) -> bool | None:
    """True/False from simplify within SIMPLIFY_SECONDS; None when it did not finish."""
    outcome: list = []

    def work() -> None:
        import sympy

        try:
            outcome.append(sympy.simplify(difference) == 0)
        except Exception:
            outcome.append(None)

    worker = threading.Thread(target=work, daemon=True)
    worker.start()
    worker.join(SIMPLIFY_SECONDS)
    return outcome[0] if outcome else None


def equivalent(answer, key, symbols: tuple[str, ...], domain: tuple[float, float] = (0.5, 3.0),
               seed: int = 0) -> bool:
    """simplify(answer - key) == 0, else equal at NUMERIC_POINTS random points of the domain
    (each symbol in +-[low, high]). A point where either side is undefined does not count; fewer
    than 8 usable points is "undecided", which is never equal."""
    import sympy

    difference = answer - key
    if _simplify_is_zero(difference):
        return True
    variables = [sympy.Symbol(s, real=True) for s in symbols]
    f_answer = sympy.lambdify(variables, answer, modules="math")
    f_key = sympy.lambdify(variables, key, modules="math")
    draw = random.Random(seed)
    agree = 0
    for _ in range(NUMERIC_POINTS * 3):
        point = [draw.choice((-1, 1)) * draw.uniform(*domain) for _ in variables]
        try:
            a, k = complex(f_answer(*point)), complex(f_key(*point))
        except (ValueError, ZeroDivisionError, OverflowError, TypeError):
            continue
        if abs(a - k) > 1e-9 * max(1.0, abs(k)):
            return False
        agree += 1
        if agree >= NUMERIC_POINTS:
            return True
    return False


def _cache_path() -> str | None:
    """Where symbolic verdicts are remembered between runs (GRADER_CACHE_DIR=off disables)."""
    import os

    folder = os.environ.get("GRADER_CACHE_DIR")
    if folder == "off":
        return None
    if not folder:
        base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        folder = os.path.join(base, "jacobians-grader")
    return os.path.join(folder, "symbolic-v1.json")


def same_expression(answer_text: str, key_text: str, symbols: tuple[str, ...], seed: int = 0) -> bool:
    """equivalent() on two answer texts, remembered on disk: sympy is imported only for a pair
    not seen before (it costs about half a second), so re-running `grade` stays fast."""
    import json
    import os

    check_text(answer_text, symbols)
    path = _cache_path()
    digest = json.dumps([answer_text, key_text, list(symbols), seed])
    cache: dict = {}
    if path and os.path.exists(path):
        try:
            with open(path, encoding="utf-8") as handle:
                cache = json.load(handle)
        except (OSError, ValueError):
            cache = {}
        if isinstance(cache.get(digest), bool):
            return cache[digest]
    result = equivalent(parse(answer_text, symbols), parse(key_text, symbols), symbols, seed=seed)
    if path:
        try:
            os.makedirs(os.path.dirname(path), exist_ok=True)
            cache[digest] = result
            temporary = f"{path}.{os.getpid()}.tmp"
            with open(temporary, "w", encoding="utf-8") as handle:
                json.dump(cache, handle)
            os.replace(temporary, path)
        except OSError:
            pass
    return result
