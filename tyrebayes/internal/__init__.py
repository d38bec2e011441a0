"""tyrebayes.internal."""
