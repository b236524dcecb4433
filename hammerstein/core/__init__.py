"""Foundations every layer above uses: the number checks and budgets, the one guard
through which every file is written (atomic replace, provenance, inputs never
outputs), bounded reads, table schemas with their messages, and lazy imports.

Imports only :mod:`hammerstein.exceptions`; models, signals, identification and
compensation live in their own sub-packages above it.
"""
