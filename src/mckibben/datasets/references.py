"""The bibliography: one record per cited work, by key.

docs/references.md is the same bibliography for readers; a test holds the two to each other.
Docstrings, published parameter sets and command output cite a work by its key in brackets
(``[wickramatunge2010]``) and print it with :meth:`Reference.short` ("Wickramatunge &
Leephakpreeda (2010)"). A field that could not be established from a source is ``None`` and
:attr:`Reference.unestablished` says which and why; nothing is guessed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from mckibben.errors import unknown_name


@dataclass(frozen=True)
class Reference:
    """One cited work.

    Parameters
    ----------
    key : str
        Bibliography key, as cited in brackets (``[wickramatunge2010]``). [-]
    title : str
        The work's title as published. [-]
    authors : tuple of str
        Family names in order; empty when they could not be established. [-]
    venue : str or None
        Journal or proceedings, with volume and pages where known. [-]
    year : int or None
        Year of publication; None when it could not be established. [-]
    doi : str or None
        DOI without the ``https://doi.org/`` prefix; None when it could not be established. [-]
    unestablished : str
        Which fields could not be established and why; empty when every field is known. [-]
    """

    key: str
    title: str
    authors: tuple[str, ...]
    venue: str | None
    year: int | None
    doi: str | None
    unestablished: str = ""

    def short(self) -> str:
        """Author–year form: "Wickramatunge & Leephakpreeda (2010)", "Davis et al. (2003)".

        A work whose authors are not established is named by its title, and one whose year is not
        established by "n.d." (no date), as author–year styles do.
        """
        if not self.authors:
            who = f"“{self.title}”"
        elif len(self.authors) == 1:
            who = self.authors[0]
        elif len(self.authors) == 2:
            who = f"{self.authors[0]} & {self.authors[1]}"
        else:
            who = f"{self.authors[0]} et al."
        return f"{who} ({self.year if self.year is not None else 'n.d.'})"

    def to_dict(self) -> dict:
        """The record as a JSON-ready dict (``year`` an int or None)."""
        return {"key": self.key, "short": self.short(), "title": self.title, "authors": list(self.authors),
                "venue": self.venue, "year": self.year, "doi": self.doi, "unestablished": self.unestablished}


REFERENCES: dict[str, Reference] = {r.key: r for r in (
    Reference(
        key="mpam-characterization",
        title="Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle",
        authors=(), venue=None, year=None, doi=None,
        unestablished="authors, venue, year and DOI: our copy of the text holds only the title, abstract"
        " and body, and no source found by title search gives them",
    ),
    Reference(
        key="wickramatunge2010",
        title="Study on mechanical behaviors of pneumatic artificial muscle",
        authors=("Wickramatunge", "Leephakpreeda"),
        venue="International Journal of Engineering Science, vol. 48, pp. 188–198", year=2010, doi=None,
        unestablished="DOI: our copy prints it with digits lost in extraction (doi:1.11/j.ijengsci.9.8.1)"
        " and no source found gives it whole",
    ),
    # works the code uses beside the two papers (docs/references.md, "Other works")
    Reference(
        key="webster2010",
        title="Design and Kinematic Modeling of Constant Curvature Continuum Robots: A Review",
        authors=("Webster", "Jones"), venue="The International Journal of Robotics Research", year=2010,
        doi="10.1177/0278364910368147",
        unestablished="volume and pages: the source found is the OnlineFirst version, without them",
    ),
    Reference(
        key="cameron2015",
        title="A Practitioner's Guide to Cluster-Robust Inference",
        authors=("Cameron", "Miller"), venue="Journal of Human Resources, vol. 50, no. 2, pp. 317–372", year=2015,
        doi="10.3368/jhr.50.2.317",
    ),
    Reference(
        key="tobin1958",
        title="Estimation of Relationships for Limited Dependent Variables",
        authors=("Tobin",), venue="Econometrica, vol. 26, no. 1, pp. 24–36", year=1958,
        doi=None, unestablished="DOI: not checked against a record of the journal's",
    ),
    Reference(
        key="akaike1974",
        title="A new look at the statistical model identification",
        authors=("Akaike",), venue="IEEE Transactions on Automatic Control, vol. AC-19, pp. 716–723", year=1974,
        doi=None, unestablished="DOI and issue: the sources found give the volume and pages only",
    ),
    Reference(
        key="levant1993",
        title="Sliding order and sliding accuracy in sliding mode control",
        authors=("Levant",), venue="International Journal of Control, vol. 58, no. 6, pp. 1247–1263", year=1993,
        doi=None, unestablished="DOI: the source found (the author's institution's record) does not give it",
    ),
    Reference(
        key="seeber2025",
        title="Proper implicit discretization of the super-twisting controller — without and with actuator saturation",
        authors=("Seeber", "Andritsch"), venue="Automatica, vol. 173, 112027", year=2025,
        doi="10.1016/j.automatica.2024.112027",
    ),
    Reference(
        key="varma2006",
        title="Bias in error estimation when using cross-validation for model selection",
        authors=("Varma", "Simon"), venue="BMC Bioinformatics, vol. 7, article 91", year=2006,
        doi="10.1186/1471-2105-7-91",
    ),
    Reference(
        key="cawley2010",
        title="On Over-fitting in Model Selection and Subsequent Selection Bias in Performance Evaluation",
        authors=("Cawley", "Talbot"), venue="Journal of Machine Learning Research, vol. 11, pp. 2079–2107", year=2010,
        doi=None, unestablished="DOI: the journal gives its papers none",
    ),
    Reference(
        key="iso6358",
        title="Pneumatic fluid power — Determination of flow-rate characteristics of components using "
              "compressible fluids — Part 1: General rules and test methods for steady-state flow",
        authors=(), venue="International Organization for Standardization, ISO 6358-1:2013, first edition",
        year=2013, doi=None,
        unestablished="authors: a standard of ISO/TC 131/SC 5, with no personal authors; DOI: ISO gives its "
                      "standards none",
    ),
    Reference(
        key="hunt2017",
        title="Modeling length effects of braided pneumatic actuators",
        authors=("Hunt", "Graber-Tilton", "Quinn"),
        venue="ASME 2017 International Design Engineering Technical Conferences and Computers and Information in "
              "Engineering Conference (IDETC/CIE), paper V05AT08A008", year=2017, doi=None,
        unestablished="DOI: we had no copy of the paper; the reference is as the authors' lab code gives it",
    ),
)}

#: A citation key in brackets, as docstrings and citation fields write it: words joined by hyphens
#: (``[mpam-characterization]``) or a name and a year (``[wickramatunge2010]``), so that units and
#: indices in brackets (``[mm]``, ``[n-1]``) are never taken for one.
KEY_PATTERN = re.compile(r"\[([a-z]{2,}(?:-[a-z]{2,})+|[a-z]{2,}[0-9]{4}[a-z]?)\]")


def reference(key: str) -> Reference:
    """The bibliography record of ``key``.

    Parameters
    ----------
    key : str
        A bibliography key, with or without its brackets. [-]

    Returns
    -------
    Reference
        The record.

    Raises
    ------
    InputError
        For an unknown key, naming it, the closest keys and all known ones.
    """
    bare = key.strip().strip("[]")
    if bare not in REFERENCES:
        raise unknown_name("citation key", key, list(REFERENCES))
    return REFERENCES[bare]


def cited(text: str) -> list[Reference]:
    """The works a citation text cites by key, in order of first mention.

    Parameters
    ----------
    text : str
        A citation field such as ``"[mpam-characterization]: Table I"``. [-]

    Returns
    -------
    list of Reference
        One record per distinct key; unknown keys raise as in :func:`reference`.
    """
    keys = list(dict.fromkeys(KEY_PATTERN.findall(text)))
    return [reference(k) for k in keys]


def render(text: str) -> str:
    """A citation text for people: each ``[key]`` as its author–year form.

    ``"[mpam-characterization]: Table I"`` reads ``"“Experimental Characterization …” (n.d.):
    Table I"``; ``"Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. (1)"`` reads
    ``"Wickramatunge & Leephakpreeda (2010), eq. (1)"`` (a key already preceded by its short form
    is dropped, not doubled).

    Parameters
    ----------
    text : str
        Text citing works by key. [-]

    Returns
    -------
    str
        The text with every key replaced.
    """
    def one(m: re.Match) -> str:
        return reference(m.group(1)).short()

    for ref in cited(text):
        text = text.replace(f"{ref.short()} [{ref.key}]", f"[{ref.key}]")
    return KEY_PATTERN.sub(one, text)
