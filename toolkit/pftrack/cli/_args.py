"""Argument types shared by the sub-commands: integers with the range their option needs.

``argparse`` names the option in its error (``pftrack run: error: argument --seed: ...``) and
exits with 2, the code of bad input.
"""

from __future__ import annotations

import argparse


def _integer(text: str, what: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None


def seed(text: str) -> int:
    """A random seed: an integer >= 0 (what :func:`numpy.random.default_rng` takes)."""
    value = _integer(text, "a random seed, an integer >= 0")
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a random seed, an integer >= 0, got {value}")
    return value


def non_negative_int(text: str) -> int:
    """An integer >= 0 (a count that may be zero)."""
    value = _integer(text, "an integer >= 0")
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {value}")
    return value


def positive_int(text: str) -> int:
    """An integer >= 1 (a stride, a number of workers, a 1-based frame number)."""
    value = _integer(text, "an integer >= 1")
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {value}")
    return value


def name_seed_options(parser: argparse.ArgumentParser) -> None:
    """Give every integer seed option a plugin added to ``parser`` (``--seed``,
    ``--scene-seed``, ...: ``type=int``) the :func:`seed` type, so that a negative seed is
    refused by the option's name before the plugin runs."""
    for action in parser._actions:
        if action.type is int and any(
                s == "--seed" or s.endswith("-seed") for s in action.option_strings):
            action.type = seed
