"""What the commands share: the option types and the action that refuses ``--opt=--``, a parser whose usage
errors stay short, and the library's messages in this command's flags.

The bounds of a value (passes, replicates, workers, time limits, noise levels) are the library's checks,
the same refusal from Python and from here; the types only read the text.
"""

from __future__ import annotations

import argparse
from typing import Any

__all__: list[str] = ["whole_number", "plain_number", "comma_names", "OneValue", "ShortErrorParser", "cli_terms"]


def whole_number(low: int = 0) -> Any:
    """An argparse type: a whole number ``>= low`` written in digits (no sign, no ``_``, under 4000 digits).

    Parameters
    ----------
    low : int
        The smallest number accepted (default 0).

    Returns
    -------
    callable
        The type: it reads an option's text as an ``int`` (surrounding blanks dropped), and its ``__name__``
        (``"integer >= low"``) names it in argparse's usage errors.

    Raises
    ------
    argparse.ArgumentTypeError
        From the type, for a text that is not such a number (echoed in at most 30 characters).

    Examples
    --------
    >>> whole_number(1)(" 12 ")
    12
    >>> whole_number(1)("0")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: '0' is not an integer >= 1
    """

    def parse(text: str) -> int:
        digits = text.strip()
        if not (digits.isdigit() and len(digits) < 4000 and int(digits) >= low):
            raise argparse.ArgumentTypeError(f"{text[:30]!r} is not an integer >= {low}")
        return int(digits)

    parse.__name__ = f"integer >= {low}"
    return parse


def plain_number(text: str) -> float:
    """An argparse type: a number (its range is the library's check), echoed short when it is not one.

    Parameters
    ----------
    text : str
        The option's text, a plain decimal number (``1_0`` is not read as 10).

    Returns
    -------
    float

    Raises
    ------
    argparse.ArgumentTypeError
        For a text that is not a number (echoed in at most 30 characters).

    Examples
    --------
    >>> plain_number("2.5e-3")
    0.0025
    >>> plain_number("1_0")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: '1_0' is not a number
    """
    from obsnl._text import plain_float  # "1_0" is not 10

    try:
        return plain_float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text[:30]!r} is not a number") from None


def comma_names(text: str) -> list[str]:
    """An argparse type: comma-separated names (``a,c``), blanks dropped.

    Parameters
    ----------
    text : str
        The option's text.

    Returns
    -------
    list of str
        The names in their order, each stripped; empty ones left out.

    Examples
    --------
    >>> comma_names("a, c,,")
    ['a', 'c']
    """
    return [x.strip() for x in text.split(",") if x.strip()]


class OneValue(argparse.Action):
    """The action of an option of one value: ``store`` (``append`` for a repeatable option), refusing the ``[]``
    that Python 3.11's argparse makes of ``--opt=--`` past the option's type and choices.

    An option is repeatable when its default is a list: each value is appended to it. Its constructor's parameters
    are :class:`argparse.Action`'s; argparse builds it from ``add_argument(..., action=OneValue)``.

    Examples
    --------
    >>> p = argparse.ArgumentParser()
    >>> _ = p.add_argument("--seed", action=OneValue)
    >>> _ = p.add_argument("--tag", action=OneValue, default=[])
    >>> p.parse_args(["--seed", "3", "--tag", "a", "--tag", "b"])
    Namespace(seed='3', tag=['a', 'b'])
    """

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        """Store ``values`` on ``namespace`` (append them for a repeatable option), or refuse an empty list.

        Parameters
        ----------
        parser : argparse.ArgumentParser
            The parser that refuses (its ``error`` exits with code 2).
        namespace : argparse.Namespace
            Where the value goes, under the option's ``dest``.
        values : Any
            The value read by the option's type; ``[]`` for ``--opt=--``.
        option_string : str or None
            The flag as written.
        """
        if isinstance(values, list) and not values:
            parser.error(
                f"argument {option_string}: expected one value, got '--' (a value that starts with '-' is "
                f"written {option_string}=VALUE)"
            )
        if isinstance(self.default, list):  # a repeatable option
            values = [*(getattr(namespace, self.dest, None) or []), values]
        setattr(namespace, self.dest, values)


class ShortErrorParser(argparse.ArgumentParser):
    """argparse's parser, whose usage errors never echo a value whole (an invalid choice, an argument it does
    not know): a message over 300 characters keeps its start and its end (where the choices are).

    Its constructor's parameters are :class:`argparse.ArgumentParser`'s.
    """

    def error(self, message: str) -> Any:  # argparse exits here (code 2)
        """Print the usage and ``message`` (its first 200 and last 80 characters when over 300) and exit with 2.

        Parameters
        ----------
        message : str
            argparse's message.

        Raises
        ------
        SystemExit
            Always, with code 2 (argparse's exit).
        """
        super().error(f"{message[:200]} ... {message[-80:]}" if len(message) > 300 else message)


def cli_terms(message: str, parser: argparse.ArgumentParser) -> str:
    """A library message in this command's terms: :func:`obsnl.errors.in_terms` with the long flags of ``parser``.

    Parameters
    ----------
    message : str
        The message, naming options as Python keywords.
    parser : argparse.ArgumentParser
        The subcommand's parser: its actions map each ``dest`` to its flag, so no table can drift.

    Returns
    -------
    str

    Examples
    --------
    >>> p = argparse.ArgumentParser()
    >>> _ = p.add_argument("--no-refine", action="store_true")
    >>> cli_terms("pass refine=False", p)
    'pass --no-refine'
    """
    from obsnl.errors import in_terms

    names = {
        a.dest: (a.option_strings[-1], a.const if a.nargs == 0 else None)
        for a in parser._actions
        if a.option_strings and a.option_strings[-1].startswith("--")
    }
    for a in (a for a in parser._actions if isinstance(a, argparse.BooleanOptionalAction)):  # --jit, --no-jit
        names |= {a.dest: (a.option_strings[0], True), f"no_{a.dest}": (a.option_strings[1], True)}
    return in_terms(message, names)
