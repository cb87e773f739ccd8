"""The ``skatelib`` command line: the entry point (:mod:`.main`, standard library only until it knows
the pipeline is installed), the app (:mod:`.app`) and its commands (:mod:`.build_commands`,
:mod:`.library_commands`)."""
