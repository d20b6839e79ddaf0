"""Theory beside measurement: added mass of primitive hulls in an unbounded fluid
(``added_mass``), a vehicle's hull as a primitive (``hull``), measured against predicted
(``compare``) and the tank's blockage (``tank``). See docs/water-and-theory.md."""
