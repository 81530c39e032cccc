"""Test doubles for the vendors' ROS boundary (written for armlab, no vendor code) and the vendor facts they rely on."""
