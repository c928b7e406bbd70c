within PendulumID;
package Examples "Test benches: the paper's friction test, the coupled rig, identification experiments"
  annotation (Documentation(info = "<html>
<p>Complete models that simulate as they are. Inputs of the components are bound by
equations (steps, sines), so every example has no free input.</p>
</html>"));
end Examples;
