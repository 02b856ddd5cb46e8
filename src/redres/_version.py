"""The version of redres, in one place: the package face, the compiler's cache stamp, the
command line, the report and the sweep manifests read it here."""

__version__ = "0.1.0.dev0"
