package sirupp.spy;

import java.awt.BorderLayout;
import java.awt.Color;
import java.awt.Dimension;
import java.awt.Graphics;
import java.awt.event.ActionEvent;
import java.awt.image.BufferedImage;
import java.io.ByteArrayInputStream;
import java.io.IOException;
import javax.imageio.ImageIO;
import javax.swing.AbstractAction;
import javax.swing.Action;
import javax.swing.JDesktopPane;
import javax.swing.JInternalFrame;
import javax.swing.JLabel;
import javax.swing.JPanel;
import javax.swing.Timer;
import lcm.spy.ChannelData;
import lcm.spy.SpyPlugin;
import sirupp.image_t;

/**
 * lcm-spy plugin: shows sirupp.image_t (VIEWER_IMAGE) as a picture. lcm-spy finds every class on
 * its classpath that implements lcm.spy.SpyPlugin; this one is in the types jar
 * (build/java/sirupp_lcmtypes.jar), so `sirupp spy` (or lcm-spy with that jar on CLASSPATH)
 * offers "Image view" in the channel's right-click menu. The window shows the newest frame
 * lcm-spy has decoded on the channel, checked ten times a second. MJPEG frames are decoded with
 * ImageIO; raw RGB, BGR, RGBA, BGRA and GREY pixels are copied; other formats are named, not drawn.
 */
public class ImagePlugin implements SpyPlugin {
  public boolean canHandle(long fingerprint) {
    return fingerprint == image_t.LCM_FINGERPRINT;
  }

  public Action getAction(JDesktopPane desktop, ChannelData channel) {
    return new ShowAction(desktop, channel);
  }

  /** The FOURCC of a pixel format as text ("MJPG"), for messages. */
  public static String fourcc(int format) {
    StringBuilder text = new StringBuilder();
    for (int i = 0; i < 4; ++i) {
      char c = (char) ((format >> (8 * i)) & 0xff);
      text.append(c >= 32 && c < 127 ? c : '?');
    }
    return text.toString();
  }

  /**
   * The picture of one image message. Throws IllegalArgumentException naming the problem for a
   * format it cannot draw, sizes that do not fit the data, or a JPEG that does not decode.
   */
  public static BufferedImage decode(image_t image) {
    if (image.width <= 0 || image.height <= 0 || image.width > 16384 || image.height > 16384) {
      throw new IllegalArgumentException(
          "size " + image.width + " x " + image.height + " (allowed 1 to 16384 pixels)");
    }
    if (image.data == null || image.size != image.data.length) {
      throw new IllegalArgumentException("size field " + image.size + " does not match the data");
    }
    if (image.pixelformat == image_t.PIXEL_FORMAT_MJPEG) {
      BufferedImage picture;
      try {
        picture = ImageIO.read(new ByteArrayInputStream(image.data));
      } catch (IOException e) {
        throw new IllegalArgumentException("JPEG does not decode: " + e.getMessage());
      }
      if (picture == null) throw new IllegalArgumentException("JPEG does not decode");
      return picture;
    }
    int channels;
    int red;
    int green;
    int blue;
    if (image.pixelformat == image_t.PIXEL_FORMAT_RGB) {
      channels = 3; red = 0; green = 1; blue = 2;
    } else if (image.pixelformat == image_t.PIXEL_FORMAT_BGR) {
      channels = 3; red = 2; green = 1; blue = 0;
    } else if (image.pixelformat == image_t.PIXEL_FORMAT_RGBA) {
      channels = 4; red = 0; green = 1; blue = 2;
    } else if (image.pixelformat == image_t.PIXEL_FORMAT_BGRA) {
      channels = 4; red = 2; green = 1; blue = 0;
    } else if (image.pixelformat == image_t.PIXEL_FORMAT_GRAY) {
      channels = 1; red = 0; green = 0; blue = 0;
    } else {
      throw new IllegalArgumentException(
          "pixel format " + fourcc(image.pixelformat) + " is not drawn (MJPG, RGB3, BGR3, RGB4, "
          + "BGR4 and GREY are)");
    }
    int stride = image.row_stride > 0 ? image.row_stride : image.width * channels;
    if (stride < image.width * channels
        || (long) stride * (image.height - 1) + (long) image.width * channels > image.data.length) {
      throw new IllegalArgumentException("row_stride " + image.row_stride + " and " + image.width
          + " x " + image.height + " pixels need more than the " + image.data.length + " bytes");
    }
    BufferedImage picture =
        new BufferedImage(image.width, image.height, BufferedImage.TYPE_INT_RGB);
    for (int y = 0; y < image.height; ++y) {
      int row = y * stride;
      for (int x = 0; x < image.width; ++x) {
        int at = row + x * channels;
        int r = image.data[at + red] & 0xff;
        int g = image.data[at + green] & 0xff;
        int b = image.data[at + blue] & 0xff;
        picture.setRGB(x, y, (r << 16) | (g << 8) | b);
      }
    }
    return picture;
  }

  /** A panel that draws the newest picture, scaled to fit, and a status line under it. */
  public static class ImagePanel extends JPanel {
    private BufferedImage picture;
    private final JLabel status = new JLabel("waiting for the first image");

    public ImagePanel() {
      setLayout(new BorderLayout());
      add(status, BorderLayout.SOUTH);
      setBackground(Color.BLACK);
      status.setForeground(Color.WHITE);
      setPreferredSize(new Dimension(640, 500));
    }

    /** Shows `image` (or names why it cannot). */
    public void display(image_t image) {
      try {
        picture = decode(image);
        status.setText(image.width + " x " + image.height + " " + fourcc(image.pixelformat)
            + ", utime " + image.utime);
      } catch (IllegalArgumentException e) {
        picture = null;
        status.setText("cannot show this image: " + e.getMessage());
      }
      repaint();
    }

    public BufferedImage picture() {
      return picture;
    }

    public String statusText() {
      return status.getText();
    }

    @Override
    protected void paintComponent(Graphics g) {
      super.paintComponent(g);
      if (picture == null) return;
      int width = getWidth();
      int height = getHeight() - status.getHeight();
      double scale = Math.min((double) width / picture.getWidth(),
          (double) height / picture.getHeight());
      int w = (int) (picture.getWidth() * scale);
      int h = (int) (picture.getHeight() * scale);
      g.drawImage(picture, (width - w) / 2, (height - h) / 2, w, h, null);
    }
  }

  /** Opens a window on the desktop that follows the channel's newest message. */
  static class ShowAction extends AbstractAction {
    private final JDesktopPane desktop;
    private final ChannelData channel;

    ShowAction(JDesktopPane desktop, ChannelData channel) {
      super("Image view");
      this.desktop = desktop;
      this.channel = channel;
    }

    public void actionPerformed(ActionEvent event) {
      final ImagePanel panel = new ImagePanel();
      final JInternalFrame frame =
          new JInternalFrame(channel.name + " (image)", true, true, true, true);
      frame.setLayout(new BorderLayout());
      frame.add(panel, BorderLayout.CENTER);
      frame.pack();
      frame.setVisible(true);
      desktop.add(frame);
      final Object[] shown = {null};
      final Timer timer = new Timer(100, null);
      timer.addActionListener(tick -> {
        if (frame.isClosed()) {
          timer.stop();
          return;
        }
        Object last = channel.last;
        if (last != shown[0] && last instanceof image_t) {
          shown[0] = last;
          panel.display((image_t) last);
        }
      });
      timer.start();
    }
  }
}
