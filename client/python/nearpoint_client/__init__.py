# SPDX-License-Identifier: Apache-2.0
"""The former name of nearpoint.client, kept so that existing scripts run: new code imports
`nearpoint.client` (or `from nearpoint import client`)."""

from nearpoint import __version__  # noqa: F401
from nearpoint.client import *  # noqa: F401,F403
