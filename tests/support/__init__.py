"""What tests share besides fixtures: the simulated rig in process (``simrig``), waiting on
conditions (``waiting``), the CLI in process (``cli``), fault proxies, a throwaway
PostgreSQL cluster (``pg``), the published data's location (``shared_data``) and the like.
Fixtures stay in the ``conftest.py`` of the folder whose tests use them."""
