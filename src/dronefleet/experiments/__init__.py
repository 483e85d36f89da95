"""The seed's four experiments (chapter 5) as runnable scenarios with reports."""
