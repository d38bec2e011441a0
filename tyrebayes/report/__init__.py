"""Reports: fits in, an HTML + Markdown page with PNG figures out (``tyrebayes demo``/``report``).

Sections are computed by :mod:`.sections` (numbers) into :mod:`.content` dataclasses, drawn by
:mod:`.figures` and written by :mod:`.writer` through :mod:`.html` and :mod:`.markdown`.
"""

from .content import Report as Report
from .writer import ReportFiles as ReportFiles
from .writer import write_report as write_report
