"""``python -m sobolev_drake`` = the ``sobolev-drake`` command."""

from sobolev_drake.cli import main

raise SystemExit(main())
