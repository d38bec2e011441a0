"""tyrebayes.simulate."""
