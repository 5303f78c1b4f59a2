"""Repeatable case studies of the thesis's chapter 6 (issue 18): the laser-speckle on/off
study on additively manufactured artefacts (ch. 6.2, tables 6.1 and 6.2)."""
