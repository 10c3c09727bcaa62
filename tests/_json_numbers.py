"""Walking a JSON object for its numbers (the unit-in-the-key checks of the CLI tests)."""

from __future__ import annotations


def json_numbers(obj, key=None):
    """(key, value) of every number in a JSON object, with the key of the innermost dict holding it.

    ``key`` is the key given to numbers outside any dict; booleans are not numbers here.
    """
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from json_numbers(v, k)
    elif isinstance(obj, list):
        for v in obj:
            yield from json_numbers(v, key)
    elif isinstance(obj, (int, float)) and not isinstance(obj, bool):
        yield key, obj
