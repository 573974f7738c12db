"""The rule studio: a tissue expert edits a rule base in the browser and sees its words become
tissue, live (``neurofuzzy studio RULES.yaml``, :func:`studio`).

- :mod:`.yamltext`: the file's text edited in place (comments, order and alignment kept);
- :mod:`.edits`: the edits the page may ask for, as data;
- :mod:`.document`: the opened file, its check (the messages of ``rules check`` with their
  lines), undo and redo, saving (atomic, only the opened file or a new one beside it);
- :mod:`.view`: what the page shows of the file and the files it extends;
- :mod:`.tissue`: a tissue's values, words and fired rules, and the poked block;
- :mod:`.fits`: fit results (``fit --json``, fit-many folders) beside the rule base;
- :mod:`.app`, :mod:`.server`: the web application (Starlette, uvicorn) and its start.

The web packages are the optional extra ``pip install 'neurofuzzy[studio]'``; everything but
:mod:`.app` and :mod:`.server` works without them.
"""

from .server import Studio, studio

__all__ = ["studio", "Studio"]
