"""``ftc-mj fdi-curves``: operating characteristics of the fault-decision rules from a finished study.

One direction, no cycle: :mod:`.cells` (the study's runs grouped into cells) → :mod:`.curves` (every
number: first alarms, ARL0, delays, isolation, Lorden's bound, the threshold sweep) → :mod:`.figures`
(drawn from the curves) → :mod:`.report` (``fdi.md``, the CSV and the figures' links).
"""
