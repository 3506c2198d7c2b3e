// SPDX-License-Identifier: BSD-3-Clause
// LcmSpyCheck: the machine-readable side of tests/apps/lcm_spy_test.sh. It runs lcm-spy itself (lcm.spy.Spy from
// lcm.jar, with the class path commerge-spy --print-classpath gives, under Xvfb) and prints, from Spy's own state:
//   type <class> <fingerprint>           every LCM type Spy's type database (lcm.spy.LCMTypeDatabase) discovered
//   READY                                Spy is subscribed; start publishing
//   channel <name> <class or ?> <fingerprint> received <n> undecodable <n> decoded <class or none>
//                                        every channel Spy saw, once <done-file> exists (or at the timeout)
// Fingerprints are 16 hex digits (the first 8 bytes of a message, big-endian). Spy keeps these in package-private
// fields (Spy.handlers, LCMTypeDatabase.classes, Spy.channelList), read here by reflection. Compiled at test time:
//   javac -cp <classpath> -d <dir> LcmSpyCheck.java; java -cp <classpath>:<dir> LcmSpyCheck <done-file> <timeout-s>
import java.io.File;
import java.lang.reflect.Field;
import java.util.ArrayList;
import java.util.List;
import java.util.Map;
import java.util.TreeMap;

public class LcmSpyCheck {
  private static Object field(Object owner, String name) throws ReflectiveOperationException {
    Field f = owner.getClass().getDeclaredField(name);
    f.setAccessible(true);
    return f.get(owner);
  }

  private static String hex(long fingerprint) {
    return String.format("%016x", fingerprint);
  }

  public static void main(String[] args) throws Exception {
    if (args.length != 2) {
      System.err.println("usage: LcmSpyCheck <done-file> <timeout-s>");
      System.exit(2);
    }
    File done = new File(args[0]);
    long deadline = System.nanoTime() + (long) (Double.parseDouble(args[1]) * 1e9);

    // Spy's constructor scans the class path for LCM types ("Found N LCM types"), opens its window and
    // subscribes to every channel on LCM_DEFAULT_URL.
    Object spy = new lcm.spy.Spy(null);

    Object database = field(spy, "handlers");
    @SuppressWarnings("unchecked")
    Map<Long, Class<?>> classes = (Map<Long, Class<?>>) field(database, "classes");
    Map<String, Long> types = new TreeMap<>();
    for (Map.Entry<Long, Class<?>> e : classes.entrySet()) types.put(e.getValue().getName(), e.getKey());
    for (Map.Entry<String, Long> e : types.entrySet()) {
      System.out.println("type " + e.getKey() + " " + hex(e.getValue()));
    }
    System.out.println("READY");
    System.out.flush();

    while (!done.exists() && System.nanoTime() < deadline) Thread.sleep(50);
    Thread.sleep(500);  // messages still in flight to Spy's LCM thread

    @SuppressWarnings("unchecked")
    List<Object> channels = (List<Object>) field(spy, "channelList");
    List<String> lines = new ArrayList<>();
    synchronized (channels) {
      for (Object c : channels) {
        lcm.spy.ChannelData cd = (lcm.spy.ChannelData) c;
        lines.add("channel " + cd.name + " " + (cd.cls == null ? "?" : cd.cls.getName()) + " " + hex(cd.fingerprint)
                  + " received " + cd.nreceived + " undecodable " + cd.nerrors + " decoded "
                  + (cd.last == null ? "none" : cd.last.getClass().getName()));
      }
    }
    lines.sort(null);
    for (String line : lines) System.out.println(line);
    System.out.println(done.exists() ? "END" : "END (timed out waiting for " + done + ")");
    System.out.flush();
    System.exit(0);
  }
}
