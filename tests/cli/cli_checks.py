# SPDX-License-Identifier: Apache-2.0
"""What the CLI test scripts in this folder share: a failed check ends the script with a message."""
import sys


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def check(condition, message):
    if not condition:
        fail(message)
