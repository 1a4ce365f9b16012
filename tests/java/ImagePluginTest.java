// The lcm-spy image plugin (lcmtypes/java/sirupp/spy/ImagePlugin.java), headless: it claims
// image_t's fingerprint and no other, draws raw and JPEG frames with the right size and pixels,
// names what it cannot draw, and its lcm-spy action opens a window that shows the channel's newest
// message. A plain main (no JUnit): prints each failure, exits 1 if there was one.
import java.awt.Color;
import java.awt.Graphics2D;
import java.awt.image.BufferedImage;
import java.io.ByteArrayOutputStream;
import javax.imageio.ImageIO;
import javax.swing.Action;
import javax.swing.JDesktopPane;
import javax.swing.JInternalFrame;
import javax.swing.SwingUtilities;
import lcm.spy.ChannelData;
import sirupp.image_t;
import sirupp.spy.ImagePlugin;

public class ImagePluginTest {
  static int failures = 0;

  static void check(boolean ok, String what) {
    if (!ok) {
      System.out.println("FAIL: " + what);
      ++failures;
    }
  }

  static image_t raw(int width, int height, int format, int channels, int stride) {
    image_t image = new image_t();
    image.utime = 1234567;
    image.width = width;
    image.height = height;
    image.row_stride = stride;
    image.pixelformat = format;
    image.data = new byte[stride * height];
    image.size = image.data.length;
    image.metadata = new sirupp.image_metadata_t[0];
    return image;
  }

  public static void main(String[] args) throws Exception {
    ImagePlugin plugin = new ImagePlugin();
    check(plugin.canHandle(image_t.LCM_FINGERPRINT), "canHandle(image_t fingerprint)");
    check(!plugin.canHandle(sirupp.arm_state_t.LCM_FINGERPRINT), "canHandle(arm_state_t) is false");
    check(!plugin.canHandle(0L), "canHandle(0) is false");

    // RGB, 5 x 3 pixels, rows padded to 16 bytes: pixel (x, y) = (10 x, 20 y, 7).
    image_t rgb = raw(5, 3, image_t.PIXEL_FORMAT_RGB, 3, 16);
    for (int y = 0; y < 3; ++y) {
      for (int x = 0; x < 5; ++x) {
        rgb.data[y * 16 + x * 3] = (byte) (10 * x);
        rgb.data[y * 16 + x * 3 + 1] = (byte) (20 * y);
        rgb.data[y * 16 + x * 3 + 2] = (byte) 7;
      }
    }
    BufferedImage picture = ImagePlugin.decode(rgb);
    check(picture.getWidth() == 5 && picture.getHeight() == 3, "RGB size 5 x 3");
    boolean same = true;
    for (int y = 0; y < 3; ++y) {
      for (int x = 0; x < 5; ++x) {
        same &= (picture.getRGB(x, y) & 0xffffff) == ((10 * x) << 16 | (20 * y) << 8 | 7);
      }
    }
    check(same, "RGB pixels as sent");

    // BGRA and GREY.
    image_t bgra = raw(2, 2, image_t.PIXEL_FORMAT_BGRA, 4, 8);
    bgra.data[0] = 1; bgra.data[1] = 2; bgra.data[2] = 3;  // B G R of pixel (0, 0)
    check((ImagePlugin.decode(bgra).getRGB(0, 0) & 0xffffff) == 0x030201, "BGRA channel order");
    image_t grey = raw(3, 1, image_t.PIXEL_FORMAT_GRAY, 1, 3);
    grey.data[2] = (byte) 200;
    check((ImagePlugin.decode(grey).getRGB(2, 0) & 0xffffff) == 0xc8c8c8, "GREY pixel");

    // JPEG (what sirupp-viewer sends by default): a 64 x 48 frame of one colour.
    BufferedImage source = new BufferedImage(64, 48, BufferedImage.TYPE_INT_RGB);
    Graphics2D g = source.createGraphics();
    g.setColor(new Color(40, 120, 200));
    g.fillRect(0, 0, 64, 48);
    g.dispose();
    ByteArrayOutputStream jpeg = new ByteArrayOutputStream();
    ImageIO.write(source, "jpg", jpeg);
    image_t mjpg = raw(64, 48, image_t.PIXEL_FORMAT_MJPEG, 0, 0);
    mjpg.data = jpeg.toByteArray();
    mjpg.size = mjpg.data.length;
    BufferedImage fromJpeg = ImagePlugin.decode(mjpg);
    check(fromJpeg.getWidth() == 64 && fromJpeg.getHeight() == 48, "JPEG size 64 x 48");
    Color centre = new Color(fromJpeg.getRGB(32, 24));
    check(Math.abs(centre.getRed() - 40) <= 4 && Math.abs(centre.getGreen() - 120) <= 4
            && Math.abs(centre.getBlue() - 200) <= 4,
        "JPEG centre pixel near (40, 120, 200), got " + centre);

    // What it cannot draw is named.
    String[] problems = new String[3];
    image_t yuyv = raw(2, 2, image_t.PIXEL_FORMAT_YUYV, 2, 4);
    image_t shortData = raw(4, 4, image_t.PIXEL_FORMAT_RGB, 3, 12);
    shortData.data = new byte[20];
    shortData.size = 20;
    image_t badJpeg = raw(8, 8, image_t.PIXEL_FORMAT_MJPEG, 0, 0);
    badJpeg.data = new byte[] {1, 2, 3};
    badJpeg.size = 3;
    image_t[] bad = {yuyv, shortData, badJpeg};
    for (int i = 0; i < bad.length; ++i) {
      try {
        ImagePlugin.decode(bad[i]);
      } catch (IllegalArgumentException e) {
        problems[i] = e.getMessage();
      }
    }
    check(problems[0] != null && problems[0].contains("pixel format YUYV"), "YUYV named: " + problems[0]);
    check(problems[1] != null && problems[1].contains("need more than the 20 bytes"),
        "short data named: " + problems[1]);
    check(problems[2] != null && problems[2].contains("JPEG does not decode"), "bad JPEG: " + problems[2]);

    // The panel draws the picture scaled into itself.
    ImagePlugin.ImagePanel panel = new ImagePlugin.ImagePanel();
    panel.display(mjpg);
    check(panel.picture() != null && panel.statusText().startsWith("64 x 48 MJPG"),
        "panel status: " + panel.statusText());
    panel.setSize(320, 280);
    panel.doLayout();
    BufferedImage screen = new BufferedImage(320, 280, BufferedImage.TYPE_INT_RGB);
    Graphics2D sg = screen.createGraphics();
    panel.paint(sg);
    sg.dispose();
    Color drawn = new Color(screen.getRGB(160, 120));
    check(Math.abs(drawn.getRed() - 40) <= 6 && Math.abs(drawn.getBlue() - 200) <= 6,
        "panel paints the frame, centre " + drawn);
    panel.display(yuyv);
    check(panel.picture() == null && panel.statusText().contains("cannot show this image"),
        "panel names an undrawable frame: " + panel.statusText());

    // lcm-spy's side: the action opens a window that follows the channel's newest message.
    ChannelData channel = new ChannelData();
    channel.name = "VIEWER_IMAGE";
    channel.fingerprint = image_t.LCM_FINGERPRINT;
    channel.last = mjpg;
    JDesktopPane desktop = new JDesktopPane();
    Action action = plugin.getAction(desktop, channel);
    check("Image view".equals(action.getValue(Action.NAME)), "action name");
    SwingUtilities.invokeAndWait(() -> action.actionPerformed(null));
    JInternalFrame[] frames = desktop.getAllFrames();
    check(frames.length == 1 && frames[0].getTitle().equals("VIEWER_IMAGE (image)"),
        "one window titled VIEWER_IMAGE (image)");
    ImagePlugin.ImagePanel shown = null;
    for (long end = System.currentTimeMillis() + 5000; System.currentTimeMillis() < end;) {
      final ImagePlugin.ImagePanel[] found = {null};
      SwingUtilities.invokeAndWait(() -> {
        for (java.awt.Component c : frames[0].getContentPane().getComponents()) {
          if (c instanceof ImagePlugin.ImagePanel
              && ((ImagePlugin.ImagePanel) c).picture() != null) {
            found[0] = (ImagePlugin.ImagePanel) c;
          }
        }
      });
      if (found[0] != null) {
        shown = found[0];
        break;
      }
      Thread.sleep(50);
    }
    check(shown != null && shown.picture().getWidth() == 64, "the window shows the channel's frame");
    SwingUtilities.invokeAndWait(() -> frames[0].doDefaultCloseAction());

    if (failures > 0) {
      System.out.println(failures + " failure(s)");
      System.exit(1);
    }
    System.out.println("image plugin: canHandle, RGB/BGRA/GREY/JPEG decode, panel paint, spy action: ok");
    System.exit(0);
  }
}
