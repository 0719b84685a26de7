"""The script language (SSML + mimika elements) and project files.

``parse_script(text) → Timeline``, ``to_script(timeline) → text`` (round trip exact),
``load_project`` / ``save_project`` for versioned JSON projects.
"""

from mimika.markup.printer import to_script
from mimika.markup.script import ScriptError, load_script, parse_script

__all__ = ["ScriptError", "load_script", "parse_script", "to_script"]
