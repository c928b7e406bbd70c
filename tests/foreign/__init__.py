"""Foreign FMUs (not made by pendfmu), their recordings and their build helper: the fixtures
of issue 13, which opens pendfmu's fitting engine to any FMU."""
