within PendulumID;
block Controller "Discrete PID controller with sample time, derivative over n_d samples, output delay, saturation and a feedforward added after it"
  parameter Real T_s(unit = "s") = 1e-3 "Sample time: samples at t_start + k*T_s";
  parameter Real K_p = 1.0 "Proportional gain";
  parameter Real K_i = 0.0 "Integral gain (per second): the integrator adds K_i*T_s*e at each sample";
  parameter Real K_d = 0.0 "Derivative gain (seconds): K_d times the difference quotient over n_d samples";
  parameter Real u_max = 1e300 "Upper saturation of the output before u_ff (1e+300: none)";
  parameter Real u_min = -1e300 "Lower saturation of the output before u_ff (-1e+300: none)";
  parameter Real u0 = 0.0 "Output (before u_ff) over the first `delay` samples, before a computed value arrives";
  parameter Integer n_d(min = 1) = 1 "Derivative span in samples: (s(k) - s(k-n_d)) / (n_d*T_s), 1..100";
  parameter Integer delay(min = 0) = 0 "Pure delay of the output in samples, 0..100";
  parameter Boolean derivative_on_measurement = false
    "The derivative acts on -y instead of the error r - y (no kick on reference steps)";
  input Real r(start = 0.0) "Reference, read at each sample";
  input Real y(start = 0.0) "Measurement, read at each sample";
  input Real u_ff(start = 0.0) "Feedforward added after the saturation, read at each sample";
  discrete output Real u(start = u0, fixed = true)
    "Controller output: saturated, delayed PID value plus u_ff, held from one sample to the next";
  discrete Real e(start = 0.0, fixed = true) "Control error r - y at the last sample";
  discrete Real v(start = 0.0, fixed = true) "Unsaturated PID value computed at the last sample";
  discrete Real u_I(start = 0.0, fixed = true) "Integrator state after the last sample";
  Integer mode(start = 0, fixed = true) "Saturation of the last computed value: -1 at u_min, 0 inside, +1 at u_max";
  Boolean saturated(start = false, fixed = true) "The last computed value was saturated";
protected
  discrete Real s(start = 0.0, fixed = true) "The signal the derivative acts on, at the last sample";
  discrete Real history[n_d](each start = 0.0, each fixed = true) "s at the last n_d samples, newest first";
  discrete Real line[max(delay, 1)](each start = u0, each fixed = true)
    "Saturated values of the last delay samples, newest first";
  discrete Real history_before[n_d](each start = 0.0, each fixed = true) "history before the shift";
  discrete Real line_before[max(delay, 1)](each start = u0, each fixed = true) "line before the shift";
  discrete Real w(start = 0.0, fixed = true) "Saturated value of the last sample";
  Integer k(start = 0, fixed = true) "Samples taken";
algorithm
  // An algorithm, not equations: rumoca 0.10.2 rejects array elements assigned in a
  // when-equation, and loops whose range is not a whole array axis (modelica/README.md).
  when sample(0, T_s) then
    e := r - y;
    s := if derivative_on_measurement then -y else e;
    if k == 0 then
      for j in 1:n_d loop
        history[j] := s;
      end for;
    end if;
    v := K_p*e + u_I + K_d*(s - history[n_d])/(n_d*T_s);
    w := min(u_max, max(u_min, v));
    u := (if delay == 0 then w else line[max(delay, 1)]) + u_ff;
    history_before := history;
    for j in 1:n_d loop
      history[j] := if j == 1 then s else history_before[max(j - 1, 1)];
    end for;
    line_before := line;
    for j in 1:max(delay, 1) loop
      line[j] := if j == 1 then w else line_before[max(j - 1, 1)];
    end for;
    if not ((v > u_max and K_i*e > 0) or (v < u_min and K_i*e < 0)) then
      u_I := u_I + K_i*T_s*e;
    end if;
    mode := if v > u_max then 1 elseif v < u_min then -1 else 0;
    saturated := mode <> 0;
    k := k + 1;
  end when;
  annotation (Documentation(info = "<html>
<p>The Controller FMU's law (pendfmu/csrc/Controller/model.c) as a sampled Modelica block. At each
sample t_k = k T_s (from time 0) it reads r, y and u_ff and computes</p>
<pre>
  e_k = r_k - y_k,   s_k = -y_k if derivative_on_measurement else e_k
  v_k = K_p e_k + I_k + K_d (s_k - s_{k-n_d}) / (n_d T_s)     (s_j = s_0 for j &lt; 0)
  w_k = min(u_max, max(u_min, v_k))
  u_k = w_{k-delay} + u_ff_k                                  (w_j = u0 for j &lt; 0)
  I_{k+1} = I_k + K_i T_s e_k, held while v_k is beyond a limit and K_i e_k pushes further
</pre>
<p>u is held between samples. EMPS: K_p = kv kp, K_d = kv, derivative_on_measurement,
n_d = 2, delay = 1, u_max = 10, u_min = -10, u_ff = pulses.</p>
<p>The FMU's locals <code>t_sample</code> and <code>t_mode</code> do not exist here; the FMU
samples from the experiment's start time, this block from time 0.</p>
</html>"));
end Controller;
