"""Publishing: the results registry, the renderer of every published text, the freshness check and
the writer every result generator uses."""
