"""What the commands show: console tables, figures and Rerun recordings."""
