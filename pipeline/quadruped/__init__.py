"""The quadruped on the skateboard. The kind's parts the build calls by name (``config`` with its
tables ``board_config`` and ``ride_config``, ``kind``, ``builder``, ``plots``, ``rerun``) and the
build's glue (``tasks``, ``entries``, ``frontier``) sit here; the rest in rooms: ``model`` (robot,
board, dynamics Eq. 3-14, schedule, riding stance), ``problem`` (the push-off NLP and its solve),
``checks`` (the independent physics checks, chain continuity) and ``transitions`` (their tasks and
the twin's judgement)."""
