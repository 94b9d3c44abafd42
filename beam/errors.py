"""Errors that are the user's to fix (bad files, bad options), as opposed to bugs.

The command line prints a :class:`BeamInputError` as one ``error: ...`` line and exits with
status 2; the dashboard shows its message and keeps the previous result.
"""


class BeamInputError(ValueError):
    """Invalid user input: a malformed file, an unknown effect, a window outside the record.

    The message is one line that names the file, row or key and says what is wrong.
    """
