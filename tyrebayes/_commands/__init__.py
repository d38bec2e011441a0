"""Sub-commands of the ``tyrebayes`` CLI, one module each (see ``tyrebayes.cli``)."""
