"""The one single-DOF equation of motion: its term library (``terms``), integrator
(``equation``), fit (``fit``), term search (``search``) and the entry for a record of one
DOF — a free decay, a forced or a pulled record (``decay.estimate_decay``)."""
