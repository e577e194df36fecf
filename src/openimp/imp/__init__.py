"""The IMP problem-oriented language: lexer, parser and VALUE expressions.

:func:`parse` (or :func:`parse_file`, :func:`parse_text`) turns a deck into a
list of :class:`Statement` objects; VALUE statements carry an
:class:`Expression` that evaluates against an environment of VALUEs and a
resolver callback for model quantities (reference: the IMP user manual, as
``docs/imp-language.md`` sums it up; ``docs/imp.md`` says where openimp departs
from it).
"""

from openimp.imp.expr import (
    Expression,
    FourierTable,
    SimulationStop,
    load_table,
    parse_expression,
    register_user,
)
from openimp.imp.lexer import SourceStatement, Token, split_statements, tokenize
from openimp.imp.parser import (
    DATA_KEYWORDS,
    FIELDS,
    JOINT_DOF,
    KINDS,
    LEADING_KEYWORDS,
    Statement,
    iter_statements,
    parse,
    parse_file,
    parse_statement,
    parse_text,
)

__all__ = [
    "DATA_KEYWORDS",
    "FIELDS",
    "JOINT_DOF",
    "KINDS",
    "LEADING_KEYWORDS",
    "Expression",
    "FourierTable",
    "SimulationStop",
    "SourceStatement",
    "Statement",
    "Token",
    "iter_statements",
    "load_table",
    "parse",
    "parse_expression",
    "parse_file",
    "parse_statement",
    "parse_text",
    "register_user",
    "split_statements",
    "tokenize",
]
