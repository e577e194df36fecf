"""Plain-numpy reference implementations in the book's notation (no openimp import):
``reference.book`` holds the oracles of the mass matrix (11.7) and of the joint
reactions (17.20) that tests/test_oracles.py checks openimp against."""
