"""Plots and HTML reports: the only place that imports matplotlib.

One module per report: ``design`` (residual creep and sweep of designs), ``tolerance`` (Monte
Carlo report), ``spice`` (ngspice against python-control), ``digital`` (digital correction),
``diagnosis`` and ``circuit_diagnosis`` (diagnose reports), ``fleet`` (the lot report of
``creepcomp fleet``), ``schematic`` (the network's schematic), ``common`` (saving figures, HTML
pages); ``tables`` (the table model: Rich, HTML and text), ``results`` (each result's tables, for
the terminal, the notebook and the HTML reports) and ``plots`` (each result's ``plot(ax=None)``).
Nothing is imported here, so that one report costs only its own imports.
"""

__all__: list[str] = []
