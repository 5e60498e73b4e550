"""The data model every layer shares: mission, sensor configuration, solution, scenarios, frames and units."""
