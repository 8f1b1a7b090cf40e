"""PNG figures (matplotlib, Agg backend): one module per figure family."""
import matplotlib

matplotlib.use("Agg")
