"""Background jobs: the ``jobs`` table is the truth, huey is the transport."""
