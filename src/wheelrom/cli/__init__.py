"""Stage 11, the command line: it parses, calls and formats, nothing else. The entry point
(:func:`wheelrom.cli.main.main`, the ``wheelrom`` command), arguments and loading
(:mod:`.args`), what is printed (:mod:`.output`, :mod:`.output_mistuning`), the file and tool
commands (:mod:`.tools`), ``animate``/``contacts`` (:mod:`.motion`), ``forced-response``
(:mod:`.forced`).

May import: every stage."""
