// Example 4: a controller in its own process, in Java, taking sirupp-control's place on the bus.
//
// It subscribes to SIM_ARM_STATE and answers every state with an arm_command_t on SIM_ARM_COMMAND
// that carries the same tick, so sirupp-sim can run in lockstep with it as the only participant:
//
//   sirupp-sim --participants java-pid          (the sim steps tick k once java-pid answered k)
//   java -cp build/java/joint_pid.jar:build/java/sirupp_lcmtypes.jar:/usr/share/java/lcm.jar \
//        -Djava.net.preferIPv4Stack=true JointPid --deg 30 -20 40 25 -30 45
//
// The law is a joint-space PID per joint, with no model of the arm: the integral term learns the
// gravity and friction efforts. The reference moves from where the arm starts towards the target
// at a limited speed, so the PID never sees a large step. Or, with --reference FILE, the reference
// is read from a file, one row per tick (what `sirupp grade` hands a process controller as
// {reference_csv}: the set-points a controller library gets, or the path of a tracking task;
// docs/grading.md): the row of each state's tick gives the position and velocity to follow.
// Gains are for the PUMA 260.
// When the states stop (the sim ended), it prints the final joint positions and exits.
//
// Options: --deg Q1 .. QN (target, degrees) or --reference FILE (one of them required)
//          --name NAME (participant, default java-pid) --lcm-url URL --prefix PREFIX (channel
//          prefix of the rig) --speed DEG_PER_S (default 30)
// Any language with LCM bindings can do the same: docs/student-controllers.md.

import java.io.BufferedReader;
import java.io.IOException;
import java.nio.file.Files;
import java.nio.file.Paths;
import java.util.ArrayList;
import java.util.List;
import lcm.lcm.LCM;
import lcm.lcm.LCMDataInputStream;
import lcm.lcm.LCMSubscriber;
import sirupp.arm_command_t;
import sirupp.arm_state_t;

public class JointPid implements LCMSubscriber {
  // PUMA 260 gains (N*m/rad, N*m/(rad*s), N*m*s/rad): about 60 rad/s of bandwidth for each
  // joint's own inertia, integral at a fifth of that.
  private static final double[] KP = {680, 640, 170, 11, 9.4, 5.5};
  private static final double[] KI = {8200, 7700, 2000, 130, 110, 66};
  private static final double[] KD = {23, 21, 5.8, 0.36, 0.31, 0.18};
  private static final double STALE_SECONDS = 1.0; // no state for this long: the sim has ended

  private final LCM lcm;
  private final String name;
  private final String commandChannel;
  private final double[] target; // rad
  private final double speed; // rad/s, the reference's top speed
  // --reference: row k is tick k, per joint position (rad or m) and velocity; null: the ramp.
  private final double[][] givenPosition;
  private final double[][] givenVelocity;

  // Controller state, touched only by LCM's receive thread (messageReceived is synchronized).
  private double[] reference; // where the joints should be now, rad
  private double[] integral; // integral of the error, rad*s
  private double[] position; // last measured, rad
  private long lastTick = -1;
  private long lastUtime = 0;
  private long seq = 0;
  private arm_command_t lastCommand;
  private long lastStateNanos = 0;
  private String failure;

  JointPid(LCM lcm, String name, String prefix, double[] target, double speed,
      double[][] givenPosition, double[][] givenVelocity) {
    this.lcm = lcm;
    this.name = name;
    this.commandChannel = prefix + "SIM_ARM_COMMAND";
    this.target = target;
    this.speed = speed;
    this.givenPosition = givenPosition;
    this.givenVelocity = givenVelocity;
  }

  @Override
  public synchronized void messageReceived(LCM source, String channel, LCMDataInputStream in) {
    arm_state_t state;
    try {
      state = new arm_state_t(in);
    } catch (IOException error) {
      System.err.println("JointPid: undecodable message on " + channel + ": " + error.getMessage());
      return;
    }
    lastStateNanos = System.nanoTime();
    if (state.num_joints != target.length) {
      failure = "the arm has " + state.num_joints + " joints, the target has " + target.length;
      notifyAll();
      return;
    }
    // Lockstep rule: answer every state with its own tick. The sim sends a state again when an
    // answer went missing; answer it with the same command instead of stepping the PID twice.
    if (state.tick == lastTick && lastCommand != null) {
      lcm.publish(commandChannel, lastCommand);
      return;
    }
    if (state.tick < lastTick) return; // older than what was answered already
    final int n = state.num_joints;
    if (reference == null) {
      reference = state.position.clone(); // start the reference where the arm is
      integral = new double[n];
    }
    final double dt = lastTick < 0 ? 0 : (state.utime - lastUtime) * 1e-6;
    arm_command_t command = new arm_command_t();
    command.utime = state.utime;
    command.seq = seq++;
    command.tick = state.tick;
    command.sender = name;
    command.mode = arm_command_t.MODE_EFFORT;
    command.num_joints = n;
    command.effort = new double[n];
    // The row of this tick (after the last row, the last row).
    final int row =
        givenPosition == null ? 0 : (int) Math.min(Math.max(state.tick, 0), givenPosition.length - 1);
    for (int j = 0; j < n; ++j) {
      double referenceSpeed;
      if (givenPosition != null) {
        reference[j] = givenPosition[row][j];
        referenceSpeed = givenVelocity[row][j];
      } else { // a ramp towards the target
        final double step = Math.max(-speed * dt, Math.min(speed * dt, target[j] - reference[j]));
        reference[j] += step;
        referenceSpeed = dt > 0 ? step / dt : 0;
      }
      final double error = reference[j] - state.position[j];
      integral[j] += error * dt;
      command.effort[j] =
          KP[j] * error + KI[j] * integral[j] + KD[j] * (referenceSpeed - state.velocity[j]);
    }
    lcm.publish(commandChannel, command);
    lastCommand = command;
    lastTick = state.tick;
    lastUtime = state.utime;
    position = state.position.clone();
  }

  // Waits until the states stop for STALE_SECONDS after the first one; true unless it failed.
  synchronized boolean awaitEnd() throws InterruptedException {
    while (failure == null) {
      if (lastStateNanos != 0 && (System.nanoTime() - lastStateNanos) * 1e-9 > STALE_SECONDS) {
        return true;
      }
      wait(100);
    }
    return false;
  }

  synchronized void printSummary() {
    if (failure != null) {
      System.err.println("JointPid: " + failure);
      return;
    }
    StringBuilder finalJoints = new StringBuilder();
    double worst = 0;
    for (int j = 0; j < target.length; ++j) {
      finalJoints.append(String.format(" %.3f", Math.toDegrees(position[j])));
      worst = Math.max(worst, Math.abs(Math.toDegrees(position[j] - target[j])));
    }
    System.out.println("JointPid: answered " + seq + " ticks, last tick " + lastTick);
    System.out.println("JointPid: final joint positions (deg):" + finalJoints);
    System.out.println(String.format("JointPid: largest error %.3f deg", worst));
  }

  // Prints the problem and the usage, and exits 2 (returns an exception only for `throw`).
  private static IllegalArgumentException usage(String problem) {
    System.err.println("JointPid: " + problem);
    System.err.println(
        "usage: JointPid (--deg Q1 .. QN | --reference FILE) [--name NAME] [--lcm-url URL]"
            + " [--prefix PREFIX] [--speed DEG_PER_S]");
    System.exit(2);
    return new IllegalArgumentException(problem);
  }

  private static double number(String text, String flag) {
    try {
      return Double.parseDouble(text);
    } catch (NumberFormatException error) {
      throw usage(flag + ": '" + text + "' is not a number");
    }
  }

  private static String value(String[] args, int i, String flag) {
    if (i >= args.length) throw usage(flag + " needs a value");
    return args[i];
  }

  // Reads a reference file ({reference_csv}): the header tick,time_s,q1_deg,v1_deg_s,a1_deg_s2,...
  // (mm for a prismatic joint), then one row per tick from 0. Returns {positions, velocities}, SI,
  // [tick][joint]; any problem exits 2 naming FILE:LINE.
  private static double[][][] readReference(String file) {
    List<String> lines;
    try {
      lines = Files.readAllLines(Paths.get(file));
    } catch (IOException error) {
      throw usage("--reference: cannot read '" + file + "': " + error.getMessage());
    }
    final String where = "--reference: " + file + ":";
    if (lines.isEmpty()) throw usage(where + "1: empty; expected the header tick,time_s,q1_deg,...");
    final String[] header = lines.get(0).split(",", -1);
    if (header.length < 5 || (header.length - 2) % 3 != 0 || !header[0].equals("tick")
        || !header[1].equals("time_s")) {
      throw usage(where + "1: header '" + lines.get(0)
          + "'; expected tick,time_s and then q,v,a per joint");
    }
    final int n = (header.length - 2) / 3;
    double[] scale = new double[n]; // SI per unit of the file
    for (int j = 0; j < n; ++j) {
      final String column = header[2 + 3 * j];
      final String q = "q" + (j + 1) + "_";
      if (column.equals(q + "deg")) {
        scale[j] = Math.PI / 180;
      } else if (column.equals(q + "mm")) {
        scale[j] = 0.001;
      } else {
        throw usage(where + "1: column " + (3 + 3 * j) + " is '" + column + "'; expected " + q
            + "deg or " + q + "mm");
      }
    }
    final int rows = lines.size() - 1;
    if (rows == 0) throw usage(where + "2: no rows after the header");
    double[][] position = new double[rows][n];
    double[][] velocity = new double[rows][n];
    for (int k = 0; k < rows; ++k) {
      final String at = where + (k + 2) + ": ";
      final String[] cells = lines.get(k + 1).split(",", -1);
      if (cells.length != header.length) {
        throw usage(at + cells.length + " values; the header has " + header.length);
      }
      double[] values = new double[cells.length];
      for (int c = 0; c < cells.length; ++c) {
        try {
          values[c] = Double.parseDouble(cells[c]);
        } catch (NumberFormatException error) {
          values[c] = Double.NaN;
        }
        if (!Double.isFinite(values[c])) {
          throw usage(at + "'" + cells[c] + "' is not a finite number");
        }
      }
      if (values[0] != k) throw usage(at + "tick " + cells[0] + "; expected " + k);
      for (int j = 0; j < n; ++j) {
        position[k][j] = values[2 + 3 * j] * scale[j];
        velocity[k][j] = values[3 + 3 * j] * scale[j];
      }
    }
    return new double[][][] {position, velocity};
  }

  public static void main(String[] args) throws Exception {
    List<Double> degrees = new ArrayList<>();
    String name = "java-pid";
    String url = null;
    String prefix = "";
    double speedDeg = 30;
    double[][][] given = null; // --reference: {positions, velocities}
    for (int i = 0; i < args.length; ++i) {
      final String flag = args[i];
      switch (flag) {
        case "--deg":
          while (i + 1 < args.length && !args[i + 1].startsWith("--")) {
            degrees.add(number(args[++i], flag));
          }
          break;
        case "--name":
          name = value(args, ++i, flag);
          break;
        case "--lcm-url":
          url = value(args, ++i, flag);
          break;
        case "--prefix":
          prefix = value(args, ++i, flag);
          break;
        case "--speed":
          speedDeg = number(value(args, ++i, flag), flag);
          break;
        case "--reference":
          given = readReference(value(args, ++i, flag));
          break;
        default:
          throw usage("unknown argument '" + flag + "'");
      }
    }
    double[] target;
    if (given != null) {
      // The target (for the final error) is where the reference ends.
      target = given[0][given[0].length - 1].clone();
      if (!degrees.isEmpty() && degrees.size() != target.length) {
        throw usage("--deg gave " + degrees.size() + " joints, --reference " + target.length);
      }
    } else {
      if (degrees.isEmpty()) throw usage("give the target with --deg, or --reference FILE");
      target = new double[degrees.size()];
      for (int j = 0; j < target.length; ++j) target[j] = Math.toRadians(degrees.get(j));
    }
    if (!(speedDeg > 0)) throw usage("--speed must be > 0");
    if (target.length > KP.length) throw usage("gains for at most " + KP.length + " joints");

    LCM lcm = url == null ? new LCM() : new LCM(url);
    JointPid controller = new JointPid(lcm, name, prefix, target, Math.toRadians(speedDeg),
        given == null ? null : given[0], given == null ? null : given[1]);
    lcm.subscribe(prefix + "SIM_ARM_STATE", controller);
    System.err.println("JointPid: participant '" + name + "', waiting for " + prefix
        + "SIM_ARM_STATE");
    final boolean ok = controller.awaitEnd();
    controller.printSummary();
    System.exit(ok ? 0 : 2);
  }
}
