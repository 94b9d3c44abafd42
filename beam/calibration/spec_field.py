"""A field of a spec read as the owner's own attribute (a setup's window, a study cell's seed).

A leaf (it imports nothing), so that the setup, which the spec's mode choice reads, can use it.
"""

from __future__ import annotations

__all__ = ["SpecField"]


class SpecField:
    """A read-only attribute that is a field of the owner's ``spec`` (a setup's, a study cell's)."""

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, instance, owner=None):
        return self if instance is None else getattr(instance.spec, self.name)
