"""Stage 11, the command line: it parses, calls and formats, nothing else. The entry point
(:mod:`.main`: :func:`wheelrom.cli.main.main`, the ``wheelrom`` command), arguments and
loading (:mod:`.args`), what is printed (:mod:`.output`, :mod:`.output_mistuning`; ``info`` by
:mod:`.output_info`, of limit-cycle and settle files by :mod:`.output_periodic`), the file and
tool commands (:mod:`.tools`), ``animate``/``contacts`` (:mod:`.motion`), ``forced-response``
(:mod:`.forced`), ``limit-cycle`` (:mod:`.limit_cycle`) and ``settle`` (:mod:`.settle`).

May import: every stage."""
