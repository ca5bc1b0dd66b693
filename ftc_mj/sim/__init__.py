"""One run: the closed loop that wires the components (:mod:`.loop`) and resolves the run record once
(:mod:`.record`), its trace writer (:mod:`.trace`),
the per-process cache of built plants and solvers (:mod:`.cache`), and a run from its config to its
output directory (:mod:`.run`, :mod:`.output`); the run summary printed after it (:mod:`.summary`)."""
