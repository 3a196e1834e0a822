// What lcm-spy does to decode a channel, without its window: scan CLASSPATH for LCM types
// (lcm.spy.LCMTypeDatabase) and look each dynfilter type up by its fingerprint; then encode
// and decode one message of each type through the Java classes.
//   java -cp lcm.jar:<this class>:dynfilter_lcmtypes.jar LcmTypesCheck reference_frame_t ...
import java.io.ByteArrayOutputStream;
import java.io.DataOutputStream;

import lcm.lcm.LCMDataInputStream;
import lcm.lcm.LCMEncodable;
import lcm.spy.LCMTypeDatabase;

public class LcmTypesCheck {
  public static void main(String[] args) throws Exception {
    LCMTypeDatabase database = new LCMTypeDatabase();
    int failures = 0;
    for (String name : args) {
      Class<?> cls = Class.forName("dynfilter." + name);
      long fingerprint = cls.getField("LCM_FINGERPRINT").getLong(null);
      Class<?> found = database.getClassByFingerprint(fingerprint);
      if (found != cls) {
        System.out.println("NOT FOUND by lcm-spy's type database: dynfilter." + name);
        ++failures;
        continue;
      }
      LCMEncodable message = (LCMEncodable) cls.getConstructor().newInstance();
      for (java.lang.reflect.Field field : cls.getFields())  // strings start out null
        if (field.getType() == String.class) field.set(message, "");
      ByteArrayOutputStream bytes = new ByteArrayOutputStream();
      message.encode(new DataOutputStream(bytes));
      byte[] encoded = bytes.toByteArray();
      Object decoded = cls.getConstructor(byte[].class).newInstance((Object) encoded);
      if (decoded.getClass() != cls) {
        System.out.println("round trip failed: dynfilter." + name);
        ++failures;
        continue;
      }
      System.out.printf("dynfilter.%s: fingerprint %016x, empty message %d bytes%n", name,
                        fingerprint, encoded.length);
    }
    System.out.println(failures == 0 ? "all types found" : failures + " types missing");
    System.exit(failures == 0 ? 0 : 1);
  }
}
