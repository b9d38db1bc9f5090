"""Printed parts as parametric CAD from RigParams (pendkit.cad.parts), their assembly and STL export."""
