"""
One case of Table 5.4: the disc-valve pump at 593 rpm and 2.76 MPa (the baseline)
=================================================================================

Headline number: the delivery per revolution of the chapter-4 model, 1.731 cc/rev in the
thesis (Table 5.4), reproduced within 0.6 % by the compiled fast path.
"""

from lumped import simulate
from studies.validation import cases

case = next(c for c in cases(valve="disc") if c["condition"] == "baseline")
result = simulate("thesis-disc", case["speed_rpm"], case["load_pressure"], air_content=case["air_content"],
                  revolutions=5, max_revolutions=20, trace=True)
delivery_cc = result.delivery_per_rev * 1e6
thesis_cc = case["thesis_modeled_delivery"] * 1e6
print(f"delivery {delivery_cc:.4f} cc/rev (thesis model {thesis_cc:.3f}, measured "
      f"{case['measured_delivery'] * 1e6:.3f}); volumetric efficiency {result.volumetric_efficiency:.4f}")
print(result.to_frame().T)

assert abs(delivery_cc / thesis_cc - 1.0) < 0.006, delivery_cc
assert result.mass_balance_error < 1e-6

# %%
# Valve openings and pressures over the last revolution (Figure 5.7's model curves)
import matplotlib.pyplot as plt

result.plot()
plt.show()
