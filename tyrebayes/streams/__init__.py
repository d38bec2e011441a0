"""tyrebayes.streams."""
