"""Independent reference models (oracles) that the tests compare the project's models against."""
